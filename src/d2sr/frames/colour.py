"""Colour images out of ROS messages (a bag's or a DDS topic's): what frame synthesis follows the camera with.
``sensor_msgs/Image`` in bgr8, rgb8 or mono8, or ``CompressedImage`` (jpeg, png); returned as OpenCV has
them (BGR, or grey)."""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from d2sr.errors import InputError
from d2sr.frames.encoded import check_encoded, check_pixels

__all__ = ["COLOUR_ENCODINGS", "PAIR_NS", "decode_colour"]

COLOUR_ENCODINGS = {"bgr8": 3, "rgb8": 3, "mono8": 1}  # encoding -> channels
PAIR_NS = 10_000_000  # a colour and a depth frame whose stamps differ by less are one moment


def decode_colour(msg: Any, where: str, compressed: bool = False) -> np.ndarray:
    """The BGR (or grey) image of one colour message; an InputError saying why for one it cannot read."""
    if compressed:
        raw = bytes(msg.data)
        check_encoded(raw, where, "PNG or JPEG")
        img = cv2.imdecode(np.frombuffer(raw, np.uint8), cv2.IMREAD_UNCHANGED)
        if img is None or img.ndim not in (2, 3) or img.dtype != np.uint8:
            raise InputError(f"{where}: CompressedImage format {str(msg.format)!r} is not 8-bit colour")
        return img if img.ndim == 2 or img.shape[2] == 3 else cv2.cvtColor(img, cv2.COLOR_BGRA2BGR)
    channels = COLOUR_ENCODINGS.get(str(msg.encoding))
    if channels is None:
        raise InputError(f"{where}: colour encoding {str(msg.encoding)!r} is not bgr8, rgb8 or mono8")
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    check_pixels(h, w, where)
    data = np.asarray(msg.data, np.uint8)
    row = w * channels
    if step < row or data.size < step * h:
        raise InputError(f"{where}: a colour image's size, step and data disagree")
    img = np.ascontiguousarray(data[: step * h].reshape(h, step)[:, :row])
    img = img.reshape(h, w, channels) if channels == 3 else img.reshape(h, w)
    return np.ascontiguousarray(img[:, :, ::-1]) if msg.encoding == "rgb8" else img
