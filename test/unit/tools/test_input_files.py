"""The shared reader of input files (collab_tools.core.input_files): every bad kind of file is refused
with the caller's error type, naming the file, before it can block, exhaust memory or crash a parser."""
import os
import struct
import zlib

import numpy as np
import pytest

from collab_tools.core.errors import ConfigurationError
from collab_tools.core.input_files import (ECHO_LIMIT, MAX_IMAGE_PIXELS, MAX_TEXT_BYTES, MAX_YAML_NODES,
                                           image_header, load_yaml_text, read_file_bytes, read_image_bytes,
                                           read_text_file, read_yaml_file)
from collab_tools.core.settings import echo


class PackageError(ConfigurationError):
    pass


def png(width, height, *, truncate=False, rows=None) -> bytes:
    """A grey 8-bit PNG; ``rows`` (height x width uint8) or zeros; ``truncate`` drops the end."""
    def chunk(kind, data):
        return struct.pack('>I', len(data)) + kind + data + struct.pack('>I', zlib.crc32(kind + data))
    pixels = rows if rows is not None else np.zeros((height, width), dtype=np.uint8)
    raw = b''.join(b'\0' + bytes(row) for row in pixels)
    data = (b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', width, height, 8, 0, 0, 0, 0))
            + chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b''))
    return data[:len(data) // 2] if truncate else data


def huge_png_header(width=10000, height=10000) -> bytes:
    """Only the header of a huge PNG (and its end): what a decoder would size its buffer by."""
    def chunk(kind, data):
        return struct.pack('>I', len(data)) + kind + data + struct.pack('>I', zlib.crc32(kind + data))
    return (b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', width, height, 8, 0, 0, 0, 0))
            + chunk(b'IEND', b''))


ALIAS_BOMB = ''.join([
    'a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]\n',
    *(f'{n}: &{n} [{", ".join([f"*{p}"] * 9)}]\n' for p, n in zip('abcdef', 'bcdefg')),
    'name: *g\n'])


def bad_file(kind: str, tmp_path) -> tuple[str, str]:
    """(path, words the error must contain) of one bad kind of text file."""
    path = tmp_path / 'bad.yaml'
    if kind == 'non-UTF-8':
        path.write_bytes(b'name: caf\xe9\n')
        return str(path), 'not UTF-8 text (byte 0xe9 at offset 9)'
    if kind == 'name over 255 bytes':
        return str(tmp_path / ('a' * 300 + '.yaml')), "NAME_MAX"
    if kind == 'path over 4095 bytes':
        return '/'.join(['b' * 200] * 25), 'PATH_MAX'
    if kind == '/dev/zero':
        return '/dev/zero', 'not a regular file (a character device)'
    if kind == 'FIFO':
        os.mkfifo(path)
        return str(path), 'not a regular file (a FIFO)'
    if kind == 'directory':
        return str(tmp_path), 'not a regular file (a directory)'
    if kind == 'missing':
        return str(tmp_path / 'nope.yaml'), 'does not exist'
    if kind == 'over 1 MiB':
        path.write_text('# ' + 'x' * MAX_TEXT_BYTES + '\nname: big\n')
        return str(path), f'(at most {MAX_TEXT_BYTES})'
    if kind == 'alias bomb':
        path.write_text(ALIAS_BOMB)
        return str(path), f'more than {MAX_YAML_NODES} values once its aliases are expanded'
    if kind == 'recursive alias':
        path.write_text('name: &a [1, *a]\n')
        return str(path), 'recursive alias'
    if kind == 'nested 100,000 deep':
        path.write_text('name: ' + '[' * 100_000 + ']' * 100_000 + '\n')
        return str(path), 'levels deep'
    if kind == 'integer of 5000 digits':
        path.write_text('name: 1' + '0' * 5000 + '\n')
        return str(path), 'cannot be built'
    if kind == 'invalid YAML':
        path.write_text('name: [1, 2\n  secret: "do not echo me"\n')
        return str(path), 'invalid YAML at line 2'
    if kind == 'empty':
        path.write_text('')
        return str(path), 'file is empty'
    raise AssertionError(kind)


TEXT_KINDS = ('non-UTF-8', 'name over 255 bytes', 'path over 4095 bytes', '/dev/zero', 'FIFO', 'directory',
              'missing', 'over 1 MiB', 'alias bomb', 'recursive alias', 'nested 100,000 deep',
              'integer of 5000 digits', 'invalid YAML', 'empty')


@pytest.mark.parametrize('kind', TEXT_KINDS)
def test_every_bad_kind_of_yaml_file_is_refused_naming_it(kind, tmp_path):
    path, words = bad_file(kind, tmp_path)
    with pytest.raises(PackageError) as caught:
        read_yaml_file(path, 'team file', PackageError)
    message = str(caught.value)
    assert message.startswith("team file '") and words in message
    assert len(message) < 400 and 'do not echo me' not in message


def test_a_good_file_with_an_alias_still_loads(tmp_path):
    path = tmp_path / 'good.yaml'
    path.write_text('placement: &p {margin: 0.2}\ntable: {placement: *p}\n')
    assert read_yaml_file(path) == {'placement': {'margin': 0.2}, 'table': {'placement': {'margin': 0.2}}}


def test_text_and_bytes_readers_bound_what_they_read(tmp_path):
    path = tmp_path / 'f.txt'
    path.write_bytes(b'x' * 100)
    assert read_file_bytes(path, max_bytes=100) == b'x' * 100
    with pytest.raises(ConfigurationError, match=r'is 100 bytes \(at most 99\)'):
        read_file_bytes(path, max_bytes=99)
    path.write_text('caf\u00e9')
    assert read_text_file(path) == 'caf\u00e9'


def test_yaml_text_has_the_same_bounds_as_a_file():
    with pytest.raises(PackageError, match='aliases are expanded'):
        load_yaml_text(ALIAS_BOMB, PackageError)
    with pytest.raises(PackageError, match='levels deep'):
        load_yaml_text('[' * 1000 + ']' * 1000, PackageError)
    assert load_yaml_text('[' * 10 + ']' * 10) == [[[[[[[[[[]]]]]]]]]]


@pytest.mark.parametrize('value', [
    'x' * 100_000, list(range(100_000)), 10 ** 5000, {'k' * 1000: 'v'},
], ids=['long string', 'long list', 'huge integer', 'long key'])
def test_echo_is_short_whatever_the_value(value):
    assert len(echo(value)) <= ECHO_LIMIT


def test_echo_of_an_alias_bomb_value_is_immediate():
    bomb = load_yaml_text('a: &a ' + '[' + ', '.join(['1'] * 9) + ']\nb: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]\n'
                          'c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b]\nd: [*c, *c, *c, *c, *c, *c, *c, *c, *c]\n')
    assert len(echo(bomb)) <= ECHO_LIMIT


def test_image_headers_give_the_size_before_decoding(tmp_path):
    assert image_header(png(3, 2)) == ('PNG', 3, 2, True)
    assert image_header(png(3, 2, truncate=True))[3] is False
    assert image_header(b'GIF89a') is None
    path = tmp_path / 'huge.png'
    path.write_bytes(huge_png_header())
    with pytest.raises(PackageError, match=rf"image file '.*huge.png': 10000 x 10000 pixels \(at most {MAX_IMAGE_PIXELS}"):
        read_image_bytes(path, error=PackageError)
    path.write_bytes(png(40, 40, truncate=True))
    with pytest.raises(PackageError, match='truncated PNG file'):
        read_image_bytes(path, error=PackageError)
    path.write_bytes(b'not an image at all')
    with pytest.raises(PackageError, match='not a PNG, JPEG, BMP or PNM'):
        read_image_bytes(path, error=PackageError)
    path.write_bytes(png(5, 4))
    data, width, height = read_image_bytes(path)
    assert (width, height) == (5, 4) and data == png(5, 4)


def test_jpeg_bmp_and_pnm_headers(tmp_path):
    cv2 = pytest.importorskip('cv2')
    image = np.zeros((7, 9), dtype=np.uint8)
    for extension, kind in (('.jpg', 'JPEG'), ('.bmp', 'BMP'), ('.pgm', 'PNM')):
        ok, encoded = cv2.imencode(extension, image)
        assert ok
        assert image_header(encoded.tobytes()) == (kind, 9, 7, True)
    ok, encoded = cv2.imencode('.jpg', image)
    assert image_header(encoded.tobytes()[:-2])[3] is False      # no end-of-image marker
