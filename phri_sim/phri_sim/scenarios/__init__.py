"""The paper's experiments as scripted scenarios and the person's choreography (pure)."""
