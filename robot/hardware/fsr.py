"""The ROBOTIS FSR foot modules (one under each sole, on the Dynamixel bus): their control table and units, as
the ROBOTIS FSR's published table gives them: the four force cells at 26, 28, 30, 32 (2 bytes each, in mN) and
the centre of pressure at 34 and 35 (1 byte each, 255 when the foot is off the ground). The right foot's module
answers at ID 111, the left's at 112.

The shipped FSR board speaks Protocol 1.0; on this robot's Protocol 2.0 bus it runs the 2.0 firmware (same
table), so it is read in the same bulk read as the OpenCR. Cells 1-4 are the sole's pads front-left,
front-right, back-left, back-right (the simulation's order).
"""

from __future__ import annotations

import numpy as np

from robot.hardware.control_table import Field

RIGHT_FSR_ID = 111
LEFT_FSR_ID = 112
MODEL_NUMBER = Field(0, 2)
FIRMWARE_VERSION = Field(2, 1)
ID = Field(3, 1)
RETURN_DELAY_TIME = Field(5, 1)
STATUS_RETURN_LEVEL = Field(16, 1)
LED = Field(25, 1)
CELLS = (Field(26, 2), Field(28, 2), Field(30, 2), Field(32, 2))
CENTRE_X = Field(34, 1)
CENTRE_Y = Field(35, 1)
TABLE_SIZE = 50
EEPROM_END = 24
NEWTON_PER_COUNT = 1e-3
TICK_BLOCK = (CELLS[0].address, CENTRE_Y.address + 1 - CELLS[0].address)  # 26 to 35


def decode_block(data: bytes) -> np.ndarray:
    """The tick's block (`TICK_BLOCK`) as the four pads' forces in N."""
    start = TICK_BLOCK[0]
    return np.array([f.decode(data[f.address - start : f.address - start + 2]) for f in CELLS]) * NEWTON_PER_COUNT


def encode_registers(forces_n: np.ndarray) -> dict[Field, int]:
    """What a module's registers hold under these pad forces (the emulator's side of `decode_block`)."""
    counts = [int(max(0, min(65535, round(float(f) / NEWTON_PER_COUNT)))) for f in forces_n]
    out = dict(zip(CELLS, counts, strict=True))
    total = sum(counts)
    if total <= 0:
        out[CENTRE_X] = out[CENTRE_Y] = 255
    else:  # 0-254 across the sole, 127 in the middle: x towards the front, y towards the left
        front = (counts[0] + counts[1]) / total
        left = (counts[0] + counts[2]) / total
        out[CENTRE_X], out[CENTRE_Y] = round(254 * front), round(254 * left)
    return out
