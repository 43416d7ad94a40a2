"""Studies over runs through the real nodes: the followability map, the paper's Figs 6-8."""
