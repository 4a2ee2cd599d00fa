"""The files users give and tools exchange, one module per format: each reads a document
once, validated, with an InputError naming the file and the field (issue 57)."""
