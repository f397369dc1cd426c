"""Edge animations: short VP9 clips a browser decodes ahead and plays back to back.

A clip of k frames of H x W pixels is stored as **VP9 in an IVF file** (``video/x-ivf``):
a 32-byte header (``DKIF``, the codec's FourCC ``VP90``, W, H, k) and then each frame as
a 12-byte header (size, timestamp) and its bytes, frame 0 a key frame. The client parses
that with a few lines of JavaScript, decodes all k frames with WebCodecs' ``VideoDecoder``
*before* the clip is due, and draws one every 1 / fps seconds (fps = 30, the scene's);
switching from one edge's clip to the next then costs no decoder start-up, which is what
makes playback gapless. A video codec shares what the frames have in common (the tank
does not move): at the same PSNR a 480 x 360 frame costs about 1.5 KB where an AVIF image
strip needs 3.2 KB and a WebP one 5-9 KB (docs/render.md, "Animation files").

Clips stored before as WebP image strips (the k frames side by side, ``image/webp``)
keep their media type and still play and decode: :func:`decode_strip` tells the two
apart by their bytes. The phone's clip (half the size) and the poster (frame 0 alone,
for the first paint) are cut from the stored clip on request.
"""

from __future__ import annotations

import io

import av
import numpy as np
from PIL import Image

from app.core.errors import InvalidInput

STRIP_MEDIA_TYPE = "video/x-ivf"
POSTER_MEDIA_TYPE = "image/webp"
IVF_MAGIC = b"DKIF"
FPS = 30
#: VP9 constant quality: 44 keeps a 480 x 360 frame near 1.5 KB at the PSNR (35 dB) of an
#: AVIF strip twice the size; "good" at cpu-used 4 encodes a clip in ~0.45 s
VP9_OPTIONS = {"crf": "44", "b:v": "0", "deadline": "good", "cpu-used": "4", "row-mt": "1"}
#: lossy WebP quality of the poster
WEBP_QUALITY = 80
#: the phone's clip is the stored one scaled by this factor (480 x 360 -> 240 x 180)
PHONE_SCALE = 0.5


def _webp(image: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(image, dtype=np.uint8)).save(
        buffer, format="WEBP", quality=WEBP_QUALITY, method=4
    )
    return buffer.getvalue()


def encode_strip(images: np.ndarray) -> bytes:
    """VP9-in-IVF bytes of the (k, H, W, 3) uint8 frames (H and W even: 4:2:0 chroma)."""
    if images.ndim != 4 or images.shape[-1] != 3:
        raise ValueError(f"expected (k, H, W, 3) RGB frames, got {images.shape}")
    k, h, w, _ = images.shape
    if h % 2 or w % 2:
        raise ValueError(f"VP9 4:2:0 frames need an even size, got {w} x {h}")
    buffer = io.BytesIO()
    with av.open(buffer, "w", format="ivf") as container:
        stream = container.add_stream("libvpx-vp9", rate=FPS, options=VP9_OPTIONS)
        stream.width, stream.height, stream.pix_fmt = w, h, "yuv420p"
        for image in images:
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image, np.uint8), "rgb24")
            container.mux(stream.encode(frame))
        container.mux(stream.encode(None))
    return buffer.getvalue()


def _video_frames(data: bytes) -> np.ndarray:
    try:
        with av.open(io.BytesIO(data), "r", format="ivf") as container:
            images = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    except av.FFmpegError as exc:
        raise InvalidInput(f"not a VP9 clip: {exc}") from None
    if not images:
        raise InvalidInput("a clip without frames")
    return np.stack(images)


def _image_strip_frames(data: bytes, frames: int) -> np.ndarray:
    strip = np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))
    h, total, _ = strip.shape
    if total % frames:
        raise InvalidInput(f"a strip {total} px wide does not hold {frames} equal frames")
    return strip.reshape(h, frames, total // frames, 3).transpose(1, 0, 2, 3)


def decode_strip(data: bytes, frames: int) -> np.ndarray:
    """(k, H, W, 3) uint8 frames of a stored clip of ``frames`` frames (VP9 or WebP strip)."""
    if not data.startswith(IVF_MAGIC):
        return _image_strip_frames(data, frames)
    images = _video_frames(data)
    if len(images) != frames:
        raise InvalidInput(f"a clip of {len(images)} frames is not one of {frames}")
    return images


def phone_strip(data: bytes, frames: int) -> bytes:
    """The clip of a stored clip's frames at :data:`PHONE_SCALE` of their size.

    The size is rounded to even numbers (VP9's 4:2:0 chroma).
    """
    images = decode_strip(data, frames)
    _, h, w, _ = images.shape
    size = (max(2, round(w * PHONE_SCALE / 2) * 2), max(2, round(h * PHONE_SCALE / 2) * 2))
    return encode_strip(
        np.stack(
            [np.asarray(Image.fromarray(i).resize(size, Image.Resampling.LANCZOS)) for i in images]
        )
    )


def encode_poster(images: np.ndarray) -> bytes:
    """WebP bytes of the first frame."""
    return _webp(images[0])
