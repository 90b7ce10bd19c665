"""collab_tools.core.image_codec: compressed_image_transport's formats, lossless labels, JPEG RGB."""
import cv2
import numpy as np
import pytest

from collab_tools.core.image_codec import LABELS_PNG_FORMAT, RGB8_JPEG_FORMAT, decode, decode_labels, \
    decode_rgb, encode_labels_png, encode_rgb_jpeg, parse_format


def table_image(height=120, width=160):
    """A top view like the bridge's: flat background, a table, coloured squares, soft edges."""
    rgb = np.full((height, width, 3), (90, 90, 100), np.uint8)
    rgb[20:100, 30:130] = (200, 180, 150)
    for row, col, colour in ((30, 40, (217, 31, 31)), (30, 70, (38, 178, 51)), (60, 100, (38, 64, 217))):
        rgb[row:row + 12, col:col + 12] = colour
    return cv2.GaussianBlur(rgb, (3, 3), 0)


def test_format_strings_are_compressed_image_transports():
    # compressed_publisher.cpp: encoding + "; jpeg compressed " + "bgr8" for colour,
    # encoding + "; png compressed " (nothing appended) for a single-channel 16-bit image.
    assert RGB8_JPEG_FORMAT == 'rgb8; jpeg compressed bgr8'
    assert LABELS_PNG_FORMAT == '16UC1; png compressed '
    assert parse_format(RGB8_JPEG_FORMAT) == ('rgb8', 'jpeg', 'bgr8')
    assert parse_format(LABELS_PNG_FORMAT) == ('16UC1', 'png', '')
    assert parse_format('jpeg') == ('', 'jpeg', '')   # the old bare form


def test_labels_round_trip_exactly():
    rng = np.random.default_rng(3)
    labels = rng.integers(0, 65536, size=(57, 83), dtype=np.uint16)   # every bit used, odd size
    labels[10:20, 10:30] = 7
    data = encode_labels_png(labels)
    decoded = decode_labels(LABELS_PNG_FORMAT, data)
    assert decoded.dtype == np.uint16 and decoded.shape == labels.shape
    assert np.array_equal(decoded, labels)
    # Byte order of the source does not matter: a big-endian array gives the same labels.
    assert np.array_equal(decode_labels(LABELS_PNG_FORMAT, encode_labels_png(labels.astype('>u2'))), labels)


def test_flat_label_images_compress_far_below_raw():
    labels = np.zeros((320, 320), np.uint16)
    labels[100:200, 80:240] = 3
    labels[140:150, 140:150] = 12
    data = encode_labels_png(labels)
    assert len(data) < labels.nbytes / 50
    assert np.array_equal(decode_labels(LABELS_PNG_FORMAT, data), labels)


def test_rgb_round_trip_within_jpeg_tolerance_and_channel_order():
    rgb = table_image()
    decoded = decode_rgb(RGB8_JPEG_FORMAT, encode_rgb_jpeg(rgb, 95))
    assert decoded.dtype == np.uint8 and decoded.shape == rgb.shape
    error = np.abs(decoded.astype(int) - rgb.astype(int))
    assert error.mean() < 2.0 and np.percentile(error, 99) <= 12
    # A red square stays red (channels not swapped on the way).
    r, g, b = decoded[36, 46]
    assert r > 180 and g < 70 and b < 70


def test_lower_quality_is_smaller():
    rgb = table_image()
    sizes = [len(encode_rgb_jpeg(rgb, q)) for q in (95, 50, 10)]
    assert sizes[0] > sizes[1] > sizes[2]


def test_decode_reads_what_the_plugin_writes_for_other_encodings():
    rgb = table_image()
    bgr_jpeg = cv2.imencode('.jpg', cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 95])[1].tobytes()
    encoding, image = decode('bgr8; jpeg compressed bgr8', bgr_jpeg)
    assert encoding == 'bgr8' and np.abs(image[..., ::-1].astype(int) - rgb).mean() < 2.0
    assert np.abs(decode_rgb('bgr8; jpeg compressed bgr8', bgr_jpeg).astype(int) - rgb).mean() < 2.0
    # Old bare form: OpenCV's BGR, returned as bgr8.
    assert decode('jpeg', bgr_jpeg)[0] == 'bgr8'
    mono = cv2.imencode('.png', rgb[:, :, 0])[1].tobytes()
    encoding, image = decode('mono8; png compressed ', mono)
    assert encoding == 'mono8' and np.array_equal(image, rgb[:, :, 0])


@pytest.mark.parametrize('format_text, data_kind, message', [
    ('rgb8; tiff compressed ', 'jpeg', "codec 'tiff'"),
    ('rgb8, jpeg', 'jpeg', "codec 'rgb8, jpeg'"),
    ('rgb8; jpeg', 'jpeg', "expected '<encoding>; <codec> compressed ...'"),
    (RGB8_JPEG_FORMAT, 'garbage', 'do not decode as jpeg'),
    (RGB8_JPEG_FORMAT, 'empty', '0 bytes do not decode'),
    ('32FC1; png compressed ', 'png16', "encoding '32FC1' is not supported"),
    ('rgb8; png compressed ', 'png16', "decoded 1 channels, 'rgb8' has 3"),
])
def test_bad_compressed_images_say_why(format_text, data_kind, message):
    data = {'jpeg': encode_rgb_jpeg(table_image(), 80), 'garbage': b'not an image at all',
            'empty': b'', 'png16': encode_labels_png(np.ones((4, 4), np.uint16))}[data_kind]
    with pytest.raises(ValueError) as error:
        decode(format_text, data)
    assert message in str(error.value)


def test_labels_refuse_jpeg_and_rgb_refuses_labels():
    with pytest.raises(ValueError, match='must be png'):
        decode_labels('16UC1; jpeg compressed mono8', encode_rgb_jpeg(table_image(), 80))
    with pytest.raises(ValueError, match="encoding '16UC1'"):
        decode_rgb(LABELS_PNG_FORMAT, encode_labels_png(np.ones((4, 4), np.uint16)))
    with pytest.raises(ValueError, match='expected 16-bit'):
        decode_labels('mono8; png compressed ', cv2.imencode('.png', np.ones((4, 4), np.uint8))[1].tobytes())


@pytest.mark.parametrize('call, message', [
    (lambda: encode_rgb_jpeg(np.zeros((4, 4), np.uint8), 90), 'HxWx3 uint8'),
    (lambda: encode_rgb_jpeg(np.zeros((4, 4, 3), np.uint8), 0), 'quality must be in [1, 100]'),
    (lambda: encode_labels_png(np.zeros((4, 4), np.int32)), 'HxW uint16'),
])
def test_bad_inputs_to_the_encoders(call, message):
    with pytest.raises(ValueError) as error:
        call()
    assert message in str(error.value)
