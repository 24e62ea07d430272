"""Figures and reports.  Plotting lives here and nowhere else in the package."""
