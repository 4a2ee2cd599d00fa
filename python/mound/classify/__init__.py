"""Coarse search: logistic regression on low-resolution multispectral pixels (Statlog).

features, logistic, metrics and reward are pure numpy/scipy with no file I/O; statlog
reads the data set, coarse trains and evaluates, model is the classifier's JSON form.
"""
