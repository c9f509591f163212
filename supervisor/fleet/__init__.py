"""The fleet prior: what the plans on other machines learned about a tool on a material."""
