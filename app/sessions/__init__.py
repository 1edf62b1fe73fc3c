"""Session storage: every run of the server or of `humanoid run` is a session in the DB."""
