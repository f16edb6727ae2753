"""Forest inventory from LiDAR and field plots: height metrics per group of returns (cells,
plots, stands), field plots and trees, area-based and tree-based volume models, stand totals
with their intervals."""
