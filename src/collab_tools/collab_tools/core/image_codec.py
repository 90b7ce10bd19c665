"""Images <-> the bytes of a sensor_msgs/CompressedImage, as compressed_image_transport does it.

The ``format`` strings are compressed_image_transport's (ROS 2 ``compressed_publisher.cpp``):
``<image encoding>; <jpeg|png> compressed <what was encoded>``, where the last part names
the colour order OpenCV encoded (``bgr8``) and is empty for single-channel images. So
RViz, Foxglove, rqt_image_view and any image_transport ``compressed`` subscriber decode
what the bridge publishes, and :func:`decode` reads what such a publisher writes.

* RGB images: JPEG (lossy; quality 1..100), ``rgb8; jpeg compressed bgr8``.
* Label images (16UC1): PNG, lossless, ``16UC1; png compressed `` (trailing space
  included: that is how the plugin writes it).

Pure numpy/OpenCV: no rclpy, so it is unit-tested on its own.
"""
from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np

#: compressed_image_transport's format strings for what the bridge publishes.
RGB8_JPEG_FORMAT = 'rgb8; jpeg compressed bgr8'
LABELS_PNG_FORMAT = '16UC1; png compressed '
#: compressed_image_transport's default png_level (zlib 0..9; PNG stays lossless at any level).
PNG_LEVEL = 3

_CHANNELS = {'rgb8': 3, 'bgr8': 3, 'mono8': 1, '8UC1': 1, 'mono16': 1, '16UC1': 1}


class CompressedFormat(NamedTuple):
    """A parsed ``format``: the image's own encoding, the codec and what was compressed."""
    encoding: str        # the raw image's encoding ('rgb8', '16UC1'; '' in the old bare 'jpeg' form)
    codec: str           # 'jpeg' or 'png'
    compressed: str      # what OpenCV encoded ('bgr8', '' for single channel)


def parse_format(text: str) -> CompressedFormat:
    """Parse a CompressedImage ``format`` (ValueError naming it if it is not jpeg/png)."""
    if ';' not in text:  # the old form: just the codec name
        codec, encoding, compressed = text.strip().lower(), '', ''
    else:
        encoding, rest = (part.strip() for part in text.split(';', 1))
        words = rest.split()
        if len(words) < 2 or words[1] != 'compressed':
            raise ValueError(f"compressed image format '{text}': expected '<encoding>; <codec> compressed ...'")
        codec, compressed = words[0].lower(), ' '.join(words[2:])
    if codec not in ('jpeg', 'png'):
        raise ValueError(f"compressed image format '{text}': codec '{codec}' (expected jpeg or png)")
    return CompressedFormat(encoding, codec, compressed)


def encode_rgb_jpeg(rgb: np.ndarray, quality: int) -> bytes:
    """JPEG bytes of an HxWx3 uint8 RGB image (format :data:`RGB8_JPEG_FORMAT`)."""
    rgb = np.asarray(rgb)
    if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f'RGB image must be HxWx3 uint8 (got {rgb.shape} {rgb.dtype})')
    if not 1 <= int(quality) <= 100:
        raise ValueError(f'JPEG quality must be in [1, 100] (got {quality})')
    # OpenCV encodes BGR: hence the plugin's 'compressed bgr8'.
    ok, data = cv2.imencode('.jpg', cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise ValueError('JPEG encoding failed')
    return data.tobytes()


def encode_labels_png(labels: np.ndarray, level: int = PNG_LEVEL) -> bytes:
    """Lossless 16-bit PNG bytes of an HxW uint16 label image (format :data:`LABELS_PNG_FORMAT`)."""
    labels = np.asarray(labels)
    if labels.dtype.kind != 'u' or labels.dtype.itemsize != 2 or labels.ndim != 2:
        raise ValueError(f'label image must be HxW uint16 (got {labels.shape} {labels.dtype})')
    ok, data = cv2.imencode('.png', labels.astype(np.uint16, copy=False), [cv2.IMWRITE_PNG_COMPRESSION, int(level)])
    if not ok:
        raise ValueError('PNG encoding failed')
    return data.tobytes()


def decode(format_text: str, data: bytes) -> tuple[str, np.ndarray]:
    """(encoding, array) of a CompressedImage, the array in that encoding's channel order.

    As compressed_image_transport's subscriber does: the part before ';' is the image's
    encoding; a colour image whose format says 'compressed bgr...' was encoded from BGR.
    ValueError (naming the format) for anything that does not decode.
    """
    parsed = parse_format(format_text)
    buffer = np.frombuffer(bytes(data), dtype=np.uint8)
    image = cv2.imdecode(buffer, cv2.IMREAD_UNCHANGED) if buffer.size else None
    if image is None:
        raise ValueError(f"compressed image ({format_text}): {len(buffer)} bytes do not decode as {parsed.codec}")
    channels = 1 if image.ndim == 2 else image.shape[2]
    encoding = parsed.encoding or {1: 'mono16' if image.dtype == np.uint16 else 'mono8', 3: 'bgr8'}.get(channels, '')
    expected = _CHANNELS.get(encoding)
    if expected is None:
        raise ValueError(f"compressed image ({format_text}): encoding '{encoding}' is not supported "
                         f"(expected one of {', '.join(_CHANNELS)})")
    if channels != expected:
        raise ValueError(f"compressed image ({format_text}): decoded {channels} channels, "
                         f"'{encoding}' has {expected}")
    if channels == 3:
        # imdecode gives BGR when the encoder was fed BGR ('compressed bgr8'), else the stored order.
        decoded_bgr = 'bgr' in parsed.compressed or not parsed.encoding
        if decoded_bgr != encoding.startswith('bgr'):
            image = image[:, :, ::-1]
    return encoding, np.ascontiguousarray(image)


def decode_rgb(format_text: str, data: bytes) -> np.ndarray:
    """HxWx3 uint8 RGB of a compressed rgb8 or bgr8 image (ValueError otherwise)."""
    encoding, image = decode(format_text, data)
    if encoding not in ('rgb8', 'bgr8'):
        raise ValueError(f"compressed image ({format_text}): encoding '{encoding}' (expected rgb8 or bgr8)")
    return image if encoding == 'rgb8' else np.ascontiguousarray(image[:, :, ::-1])


def decode_labels(format_text: str, data: bytes) -> np.ndarray:
    """HxW uint16 label image of a PNG-compressed 16UC1/mono16 image (ValueError otherwise).

    JPEG is refused: it is lossy and would invent labels at every edge.
    """
    parsed = parse_format(format_text)
    if parsed.codec != 'png':
        raise ValueError(f"compressed labels ({format_text}): must be png (lossless), not {parsed.codec}")
    encoding, image = decode(format_text, data)
    if image.dtype != np.uint16 or image.ndim != 2:
        raise ValueError(f"compressed labels ({format_text}): decoded {image.dtype} with {image.ndim} dimensions "
                         f"(expected 16-bit single channel, encoding '{encoding}')")
    return image
