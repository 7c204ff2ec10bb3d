"""The inspection engine: read → register → measure deviations → judge. numpy/scipy only."""
