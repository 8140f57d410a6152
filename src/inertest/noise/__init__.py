"""Allan-family deviations and noise identification."""
