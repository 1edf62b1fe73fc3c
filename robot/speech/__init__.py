"""Speech: recognising spoken commands (ASR engines) and speaking (TTS)."""
