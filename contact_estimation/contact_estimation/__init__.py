"""Per-link contact centre, wrench and contact region from taxel arrays (paper Sec. IV-A)."""
