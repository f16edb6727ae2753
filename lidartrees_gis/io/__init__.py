"""Readers and writers: points (XYZ text, LAS/LAZ), rasters (GeoTIFF), vectors (GeoPackage)."""
