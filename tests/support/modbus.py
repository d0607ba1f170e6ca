"""Small helpers shared by the Python test programs."""


def with_crc(body):
    """An RTU ADU: slave address and PDU, then CRC-16/MODBUS, low byte first."""
    crc = 0xFFFF
    for byte in body:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return bytes(body) + bytes([crc & 0xFF, crc >> 8])
