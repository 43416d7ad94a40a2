"""Offline reports: figure panels, the paper's figures, the following report, video."""
