"""What runs mean: snapshot diagnostics, time-series statistics, equilibria, comparisons, fits."""
