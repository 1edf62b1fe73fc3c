"""The real robot's sensor drivers that are not on the servo bus (a BNO055 IMU, the head camera, the lidar), each
with an emulator of its wire protocol for tests."""
