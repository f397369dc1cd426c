"""A contact sheet: frames in a grid, each with a caption saying what it shows.

A reader of a report cannot ask which edge a picture is; the caption tells the edge
(vertex and control, simulated or blended), the frame of its clip, and how often play
passed there; a title names the graph and publication.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw, ImageFont

#: narrower frames are enlarged (by a whole factor, pixels kept sharp) to fit a caption
MIN_TILE_WIDTH = 180
#: caption text size (px) and the space a line takes under each tile
CAPTION_SIZE = 12
LINE_HEIGHT = 16
MARGIN = 4
BACKGROUND = (255, 255, 255)
INK = (20, 20, 20)


@dataclass(frozen=True)
class Tile:
    image: np.ndarray
    #: lines under the image
    caption: tuple[str, ...]


def contact_sheet(title: str, tiles: list[Tile], columns: int = 4) -> np.ndarray:
    """(H, W, 3) uint8: ``title`` on top, then the tiles in rows of ``columns``, captioned.

    Every tile's image must have the first one's shape.
    """
    if not tiles:
        raise ValueError("a contact sheet needs at least one tile")
    scale = -(-MIN_TILE_WIDTH // tiles[0].image.shape[1])
    height, width = (scale * n for n in tiles[0].image.shape[:2])
    lines = max(len(tile.caption) for tile in tiles)
    cell_w, cell_h = width + 2 * MARGIN, height + lines * LINE_HEIGHT + 2 * MARGIN
    rows = -(-len(tiles) // columns)
    top = LINE_HEIGHT + 2 * MARGIN
    font = ImageFont.load_default(size=CAPTION_SIZE)
    sheet_w = max(columns * cell_w, int(font.getlength(title)) + 2 * MARGIN)
    sheet = Image.new("RGB", (sheet_w, top + rows * cell_h), BACKGROUND)
    draw = ImageDraw.Draw(sheet)
    draw.text((MARGIN, MARGIN), title, fill=INK, font=font)
    for i, tile in enumerate(tiles):
        x, y = (i % columns) * cell_w + MARGIN, top + (i // columns) * cell_h + MARGIN
        image = np.asarray(tile.image, dtype=np.uint8).repeat(scale, axis=0).repeat(scale, axis=1)
        sheet.paste(Image.fromarray(image), (x, y))
        for line, text in enumerate(tile.caption):
            draw.text((x, y + height + line * LINE_HEIGHT + 2), text, fill=INK, font=font)
    return np.asarray(sheet)
