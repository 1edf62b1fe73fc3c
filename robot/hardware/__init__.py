"""The real robot's hardware: Dynamixel XM430 servos (what they report, and how)."""
