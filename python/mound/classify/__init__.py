"""Coarse search: logistic regression on low-resolution multispectral pixels.

Pure numpy/scipy, no file I/O (the CLI and mound.model_io do the I/O).
"""
