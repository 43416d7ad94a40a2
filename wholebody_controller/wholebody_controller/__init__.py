"""Admittance at every contact centre, soft dynamic priorities, one QP for a
mecanum base and two arms."""
