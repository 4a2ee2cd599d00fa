"""Coarse search on real satellite scenes: GeoTIFF and known mounds in, p(mound) rasters
and ranked candidate sites out (raster: the scene reader; vector: the GeoJSON readers;
features, model, train, score, evaluate: pure numpy/scipy; cli: `mound scene`)."""
