"""Photos from the aircraft: a card sorted into the scanned sites (`mound photos sort`)."""
