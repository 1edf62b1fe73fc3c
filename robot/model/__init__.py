"""Robot and world models: the one place for the robot's constants and the apartment it lives in."""
