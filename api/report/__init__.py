"""A plan's record for people: the HTML report, its plots, tidy tables and the web view."""
