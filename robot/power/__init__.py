"""Power: the servos' electrical load and the battery pack that feeds them."""
