"""Metrics of one run: per scenario, following, contact forces against ISO/TS 15066 (pure)."""
