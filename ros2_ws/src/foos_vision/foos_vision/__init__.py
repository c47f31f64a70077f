"""Camera tracker for the foosball table (filled by the vision issue)."""
