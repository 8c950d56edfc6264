#!/usr/bin/python3
"""One frame of a PointOdyssey sequence folder as a 2x2 picture: RGB (rgbs/, from odyssey render),
depth, normals and instance mask, each read as the trackers' loaders read them.

usage: scripts/sequence_figure.py SEQUENCE_DIR FRAME OUT.png [--width W]

Depth is decoded as value / 65535 * 1000 metres and drawn as inverse depth (near bright, no
surface black); normals are the JPEG as written ((n + 1) / 2 of the world normal); mask ids get
distinct colours (0, no surface, black). Needs numpy and PIL (Debian: python3-numpy, python3-pil).
"""
import argparse
import colorsys
import sys
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw


def tile(image, width, label):
    height = round(image.height * width / image.width)
    image = image.convert("RGB").resize((width, height), Image.LANCZOS)
    draw = ImageDraw.Draw(image)
    draw.rectangle((0, 0, 8 + 7 * len(label), 16), fill=(0, 0, 0))
    draw.text((4, 2), label, fill=(255, 255, 255))
    return image


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sequence", type=Path)
    parser.add_argument("frame", type=int)
    parser.add_argument("out", type=Path)
    parser.add_argument("--width", type=int, default=480, help="width of each of the four pictures (pixels)")
    args = parser.parse_args()
    name = f"{args.frame:05d}"
    paths = {
        "rgb": args.sequence / "rgbs" / f"rgb_{name}.jpg",
        "depth": args.sequence / "depths" / f"depth_{name}.png",
        "normal": args.sequence / "normals" / f"normal_{name}.jpg",
        "mask": args.sequence / "masks" / f"mask_{name}.png",
    }
    for what, path in paths.items():
        if not path.is_file():
            hint = " (run odyssey render on the sequence first)" if what == "rgb" else ""
            sys.exit(f"{path}: no such file{hint}")

    depth = np.asarray(Image.open(paths["depth"])).astype(np.float64)
    metres = depth / 65535.0 * 1000.0
    surface = depth < 65535
    inverse = np.zeros_like(metres)
    inverse[surface] = 1.0 / metres[surface]
    if surface.any():
        low, high = np.percentile(inverse[surface], [1, 99])
        inverse[surface] = np.clip((inverse[surface] - low) / max(high - low, 1e-9), 0, 1) * 0.85 + 0.15
    depth_image = Image.fromarray((inverse * 255).astype(np.uint8))

    mask = np.asarray(Image.open(paths["mask"]))
    palette = np.zeros((256, 3), np.uint8)
    for i in range(1, 256):
        r, g, b = colorsys.hsv_to_rgb((i * 0.618034) % 1.0, 0.65, 0.95)
        palette[i] = (round(r * 255), round(g * 255), round(b * 255))
    mask_image = Image.fromarray(palette[mask])

    width = args.width
    tiles = [tile(Image.open(paths["rgb"]), width, "rgb (Blender Cycles)"), tile(depth_image, width, "depth"),
             tile(Image.open(paths["normal"]), width, "normals"), tile(mask_image, width, "instance mask")]
    height = tiles[0].height
    sheet = Image.new("RGB", (2 * width, 2 * height))
    for i, image in enumerate(tiles):
        sheet.paste(image, ((i % 2) * width, (i // 2) * height))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    sheet.save(args.out)


if __name__ == "__main__":
    main()
