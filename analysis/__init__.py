"""Contact area to resistance, normalisation, fits of measured against simulated curves, figures, reports."""
