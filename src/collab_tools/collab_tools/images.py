"""sensor_msgs/Image <-> numpy for the encodings the bridge publishes."""

import numpy as np
from sensor_msgs.msg import Image


def image_array(msg: Image) -> np.ndarray:
    """numpy view of an rgb8 or 16UC1 image; ValueError for anything else or a bad size."""
    if msg.encoding == 'rgb8':
        dtype, channels = np.uint8, 3
    elif msg.encoding == '16UC1':
        dtype, channels = np.dtype('>u2' if msg.is_bigendian else '<u2'), 1
    else:
        raise ValueError(f"image encoding '{msg.encoding}' (expected rgb8 or 16UC1)")
    itemsize = np.dtype(dtype).itemsize
    row = msg.width * channels * itemsize
    if msg.step < row or len(msg.data) < msg.step * msg.height:
        raise ValueError(f'image data size {len(msg.data)} does not match {msg.height}x{msg.width} '
                         f'step {msg.step}')
    data = np.frombuffer(bytes(msg.data), dtype=np.uint8).reshape(msg.height, msg.step)[:, :row]
    array = data.copy().view(dtype).reshape(msg.height, msg.width, channels)
    return array[:, :, 0] if channels == 1 else array
