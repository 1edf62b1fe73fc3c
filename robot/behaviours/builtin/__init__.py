"""The built-in behaviours (registered as entry points in the project's pyproject, like anyone's)."""
