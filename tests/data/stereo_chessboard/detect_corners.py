"""How corners.csv and board.csv were made (run once; the images are not kept in the repository).

    python detect_corners.py IMAGE_DIR

IMAGE_DIR holds left01.jpg … left25.jpg and right01.jpg … right25.jpg of the source named in README.md.
Corners: cv2.findChessboardCornersSB, 9 × 6 inner corners; a view is kept when the board is found in both
images; the right image's corner order is reversed when it runs the other way from the left one's (the
board's 180° ambiguity), checked on the direction from the first to the last corner.
"""

import sys
from pathlib import Path

import cv2
import numpy as np

COLUMNS, ROWS, SQUARE_M = 9, 6, 0.024


def corners(path: Path):
    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    found, points = cv2.findChessboardCornersSB(image, (COLUMNS, ROWS), flags=cv2.CALIB_CB_ACCURACY)
    return (points.reshape(-1, 2).astype(np.float64) if found else None), image.shape[::-1]


def main(folder: str) -> None:
    here = Path(__file__).parent
    rows = ["id,xl,yl,xr,yr,pair"]
    for k in range(1, 26):
        left, size = corners(Path(folder) / f"left{k:02d}.jpg")
        right, _ = corners(Path(folder) / f"right{k:02d}.jpg")
        if left is None or right is None:
            print(f"view {k:02d}: board not found in both images; left out")
            continue
        if np.dot(left[-1] - left[0], right[-1] - right[0]) < 0:
            right = right[::-1]
        for i, (a, b) in enumerate(zip(left, right, strict=True)):
            rows.append(f"{i},{a[0]:.4f},{a[1]:.4f},{b[0]:.4f},{b[1]:.4f},{k:02d}")
    (here / "corners.csv").write_text("\n".join(rows) + "\n")
    board = ["id,X,Y,Z"] + [f"{r * COLUMNS + c},{c * SQUARE_M:.3f},{r * SQUARE_M:.3f},0"
                            for r in range(ROWS) for c in range(COLUMNS)]
    (here / "board.csv").write_text("\n".join(board) + "\n")
    print(f"image size {size[0]} x {size[1]}; {len(rows) - 1} corner pairs")


if __name__ == "__main__":
    main(sys.argv[1])
