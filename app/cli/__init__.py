"""The `humanoid` command line."""
