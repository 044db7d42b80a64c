"""The XOR checksum of NMEA 0183 and of the TruPulse ``$PLTIT`` sentences."""


def xor_checksum(body: str) -> int:
    """XOR of every character between ``$`` and ``*``."""
    value = 0
    for ch in body.encode("ascii"):
        value ^= ch
    return value
