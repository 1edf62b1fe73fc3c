"""An example behaviour package for the humanoid console (`wave_hello.behaviour.WaveHello`)."""
