"""Reading a greyscale depth map: grey level to height (Borangiu et al., IFAC 2007, §3).

"The pixel's coordinates in the image map to the real variables x and y, and the grey level
encodes the z value. Usually the black colour maps to the lowest z level and the white colour
maps to the highest." 8-bit images give 256 levels, 16-bit 65536. ``negative`` complements
the grey levels (the paper's negative image, from which a mould is machined).

Coordinates: pixel ``(row, col)`` has its centre at ``x = col·p``, ``y = (rows − 1 − row)·p``
[mm], so the image's top is +Y, as on screen.
"""

from __future__ import annotations

import math
import re
import struct
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from models.errors import MAX_ECHO, InputError

#: The largest map accepted (pixels per side): 16 M pixels at most.
MAX_SIDE_PX = 4000
#: The most pixels of a map: checked from the image's header, before a pixel is decoded (a
#: 1.9 MB TIFF of 30000 x 30000 decodes to 1.8 GB of 16-bit pixels, and more as it is read).
MAX_PIXELS = MAX_SIDE_PX * MAX_SIDE_PX
#: The smallest map: the contours and the dilation need a few pixels.
MIN_SIDE_PX = 8
#: The largest |z| and pixel size accepted [mm].
MAX_MM = 1.0e4


@dataclass(frozen=True, eq=False)
class DepthMap:
    """A height field on a pixel grid.

    Parameters
    ----------
    height_mm : ndarray
        ``z`` at each pixel centre [mm], ``float64``, shape ``(rows, cols)``.
    pixel_mm : float
        Pixel size [mm].
    z_low_mm, z_high_mm : float
        The heights of grey level 0 and of full scale [mm].
    levels : int
        Number of grey levels of the image (256, 65536); one grey level is
        ``(z_high − z_low) / (levels − 1)``.
    stock_top_mm : float
        Top of the stock [mm], at or above the highest pixel.
    """

    height_mm: NDArray[np.float64]
    pixel_mm: float
    z_low_mm: float
    z_high_mm: float
    levels: int
    stock_top_mm: float

    @property
    def grey_level_mm(self) -> float:
        """The height of one grey level [mm]."""
        return (self.z_high_mm - self.z_low_mm) / (self.levels - 1)

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)``."""
        rows, cols = self.height_mm.shape
        return int(rows), int(cols)

    @property
    def width_mm(self) -> float:
        """Extent in X between the outer pixel centres [mm]."""
        return (self.shape[1] - 1) * self.pixel_mm

    @property
    def length_mm(self) -> float:
        """Extent in Y between the outer pixel centres [mm]."""
        return (self.shape[0] - 1) * self.pixel_mm


def parse_z_range(text: str, field: str = "z_range_mm") -> tuple[float, float]:
    """``"LO:HI"`` as two finite numbers with ``LO < HI`` [mm]."""
    low_text, sep, high_text = text.partition(":")
    if not sep:
        raise InputError(field, text, "must be LO:HI in mm, e.g. 0:20")
    try:
        low, high = float(low_text), float(high_text)
    except ValueError:
        raise InputError(field, text, "must be LO:HI in mm, two numbers") from None
    if not (math.isfinite(low) and math.isfinite(high)) or max(abs(low), abs(high)) > MAX_MM:
        raise InputError(field, text, f"must be finite and within ±{MAX_MM:g} mm")
    if not low < high:
        raise InputError(field, text, "LO must be below HI")
    return low, high


def grey_to_depthmap(
    grey: NDArray[np.integer],
    levels: int,
    pixel_mm: float,
    z_range_mm: tuple[float, float],
    *,
    negative: bool = False,
    stock_top_mm: float | None = None,
) -> DepthMap:
    """Heights from grey levels: ``z = z_low + g / (levels − 1) · (z_high − z_low)``.

    Parameters
    ----------
    grey : ndarray of int
        Grey levels ``0 .. levels − 1``, shape ``(rows, cols)``.
    levels : int
        256 (8-bit) or 65536 (16-bit).
    pixel_mm : float
        Pixel size [mm].
    z_range_mm : (float, float)
        Heights of black and of white [mm].
    negative : bool
        Complement the grey levels first (``g → levels − 1 − g``), the paper's negative image.
    stock_top_mm : float, optional
        Top of the stock [mm]; default the top of the z range. Not below the highest pixel.

    References
    ----------
    .. [1] Borangiu et al., Embedded numeric-adaptive machining control based on data fusion,
       IFAC 2007, §3 (depth map images, Figs. 1-2).
    """
    if not (math.isfinite(pixel_mm) and 0 < pixel_mm <= 100):
        raise InputError("pixel_mm", pixel_mm, "must be a pixel size in mm, > 0 and <= 100")
    rows, cols = grey.shape
    if min(rows, cols) < MIN_SIDE_PX or max(rows, cols) > MAX_SIDE_PX:
        raise InputError(
            "image",
            f"{cols}x{rows} pixels",
            f"each side must be {MIN_SIDE_PX} to {MAX_SIDE_PX} pixels",
        )
    low, high = z_range_mm
    top = levels - 1
    g = grey.astype(np.float64)
    if negative:
        g = top - g
    height = low + g / top * (high - low)
    stock = high if stock_top_mm is None else float(stock_top_mm)
    peak = float(height.max())
    if not math.isfinite(stock) or abs(stock) > MAX_MM:
        raise InputError("stock_top_mm", stock_top_mm, "must be a finite height in mm")
    if stock < peak - 1e-9:
        raise InputError(
            "stock_top_mm", stock_top_mm, f"is below the highest point of the map ({peak:.4g} mm)"
        )
    return DepthMap(height, float(pixel_mm), low, high, levels, stock)


def read_depthmap(
    path: Path,
    pixel_mm: float,
    z_range_mm: tuple[float, float],
    *,
    negative: bool = False,
    stock_top_mm: float | None = None,
) -> DepthMap:
    """Read an 8- or 16-bit greyscale PNG or TIFF as a :class:`DepthMap`.

    An RGB(A) image whose three colour channels are equal is read as grey (many programs save
    grey that way); any other colour image, a float image or a 1-bit one is refused.
    """
    from skimage import io  # heavy; imported when an image is read

    if not path.is_file():
        raise InputError("image", str(path), "no such file")
    _check_size(path)
    try:
        data = np.asarray(io.imread(str(path)))
    except Exception as err:  # noqa: BLE001 - any reader failure is a bad file
        why = str(err)[:MAX_ECHO]
        raise InputError("image", str(path), f"cannot be read as an image ({why})") from None
    data = _grey_channel(data, str(path))
    if data.dtype == np.uint8:
        levels = 256
    elif data.dtype == np.uint16:
        levels = 65536
    else:
        raise InputError("image", str(path), f"must be 8- or 16-bit greyscale, not {data.dtype}")
    return grey_to_depthmap(
        np.asarray(data, dtype=np.int64),
        levels,
        pixel_mm,
        z_range_mm,
        negative=negative,
        stock_top_mm=stock_top_mm,
    )


def _check_size(path: Path) -> None:
    """Refuse an image over :data:`MAX_SIDE_PX` a side from its header, before decoding it.

    Pillow's ``Image.open`` reads the header only (PNG's IHDR, TIFF's first IFD); its own
    bomb guard (``Image.MAX_IMAGE_PIXELS``, left as it is) raises at twice its limit, far above
    this one, and only warns between. A TIFF Pillow cannot open is measured by tifffile's
    header reader; any other file is left to the decoder, which refuses it.
    """
    from PIL import Image, UnidentifiedImageError

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(path) as im:
                cols, rows = im.size
    except Image.DecompressionBombError as err:  # over 2 x Image.MAX_IMAGE_PIXELS
        shape = _png_shape(path) or _tiff_shape(path)
        found = re.search(r"\((\d+) pixels\)", str(err))
        pixels = f"{int(found.group(1))} pixels" if found else "over Pillow's limit"
        size = f"{shape[1]} x {shape[0]} pixels" if shape else pixels
        raise InputError("image", str(path), _too_large(size)) from None
    except (UnidentifiedImageError, OSError, ValueError):
        shape = _tiff_shape(path)
        if shape is None:
            return  # no image Pillow or tifffile knows: the decoder says so
        rows, cols = shape
    if max(rows, cols) > MAX_SIDE_PX:
        raise InputError("image", str(path), _too_large(f"{cols} x {rows} pixels"))


def _png_shape(path: Path) -> tuple[int, int] | None:
    """Rows and columns of a PNG from its IHDR chunk, or None when it is no PNG."""
    with path.open("rb") as file:
        head = file.read(24)
    if len(head) < 24 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        return None
    cols, rows = struct.unpack(">II", head[16:24])
    return rows, cols


def _tiff_shape(path: Path) -> tuple[int, int] | None:
    """Rows and columns of a TIFF's first image from its header (tifffile), or None."""
    import tifffile

    try:
        with tifffile.TiffFile(path) as tif:
            page = tif.pages.first
            return int(page.imagelength), int(page.imagewidth)
    except (tifffile.TiffFileError, OSError, ValueError, AttributeError):
        return None


def _too_large(size: str) -> str:
    return (
        f"is {size} (from its header); a depth map is at most {MAX_SIDE_PX} x {MAX_SIDE_PX} "
        "pixels: refused before decoding"
    )


def _grey_channel(data: NDArray[np.generic], name: str) -> NDArray[np.generic]:
    if data.ndim == 2:
        return data
    if data.ndim == 3 and data.shape[2] in (3, 4):
        colour = data[:, :, :3]
        if np.array_equal(colour[:, :, 0], colour[:, :, 1]) and np.array_equal(
            colour[:, :, 0], colour[:, :, 2]
        ):
            return colour[:, :, 0]
        raise InputError("image", name, "is a colour image, not greyscale")
    raise InputError("image", name, f"is not a greyscale image (array shape {data.shape})")
