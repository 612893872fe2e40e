"""The error every driver raises when a device cannot be opened or used."""


class DeviceError(Exception):
    """A device cannot be opened, read or written (its message names the device)."""


__all__ = ["DeviceError"]
