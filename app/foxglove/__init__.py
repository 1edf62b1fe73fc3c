"""The robot for Foxglove and Lichtblick: the same topics, schemas and frames in exported sessions (MCAP) and on
the live WebSocket server."""
