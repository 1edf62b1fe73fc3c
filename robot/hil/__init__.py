"""The hardware-in-the-loop rig: physics behind the emulated devices (see `robot.hil.rig`)."""
