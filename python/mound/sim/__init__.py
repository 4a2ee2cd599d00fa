"""Site simulator: terrain with or without a tumulus, its appearance, the rendered UAV
images with ground truth (site.py) and their figures."""
