"""A second renderer of the ground the optical sensors see: PyBullet's own off-screen camera (TinyRenderer), for
validating ``GroundTexture.patches`` (which cuts the same patches out of the texture with OpenCV).

``CameraGround`` adds to a PyBullet client a visual-only, textured copy of the ground tile, repeated ``tiles`` x
``tiles`` times around the origin, and renders each patch with a camera looking straight down at it. It has the same
``patches(affines, size_px)`` method and conventions as ``GroundTexture``, so an ``OpticalSensor`` can use either.

The mapping, as measured (see tests/test_camera.py):
- Texture: the tile is saved as an 8-bit PNG with its rows as they are (row 0 = smallest world y). TinyRenderer
  samples textures with v = 0 at the image's *last* row, so a tile quad's uvs are u = (x - x0) / length and
  v = 1 - (y - y0) / width. It samples the nearest texel, at no other scale (no power-of-two resize): texel
  floor(u * columns), floor((1 - v) * rows), which is exactly the texel whose centre is nearest in the numpy
  texture's convention. There are no seams at triangle edges or tile edges (uvs stay in [0, 1] on every quad).
- Camera: instead of a look-at matrix, the view matrix is the inverse of the patch's affine, so any rotation, pixel
  size, mirror or shear of the footprint is reproduced exactly; the projection is a 90 degree perspective, the eye
  1 m above the ground. TinyRenderer samples the screen at integer pixel coordinates (not pixel centres) and puts
  screen y up with image row 0 at the top, so the camera is centred half a pixel off the patch centre, at offset
  (u, v) = (+1/2, -1/2) px; then image pixel (column i, row j) shows the ground point of the affine at
  (i - (size - 1) / 2, j - (size - 1) / 2), as in ``GroundTexture.patches``.
- Lighting: ambient coefficient 1, no diffuse, specular or shadow: the rendered grey level is the texel's.
- Only the ground is seen: the near and far planes keep a band of +-2 mm around the ground, so bodies resting on it
  (their downward faces are also culled) never show. The textured copy lies 0.1 mm above z = 0: a World's ground
  plane (collision-only) is drawn by TinyRenderer too, at z = 0, and would otherwise hide the texture. At 1 m eye
  height the 0.1 mm lift changes the image scale by 1e-4.

Cost: about 0.3 ms per 32 px patch (one getCameraImage each), 20 to 50 times GroundTexture's.
"""

from __future__ import annotations

import math
import os
import tempfile

import cv2
import numpy as np
import pybullet as pb

from morphbench.sensing.ground import GroundTexture

EYE_HEIGHT = 1.0
"""m, height of the camera above the ground."""
CLIP = 0.002
"""m, the camera sees only from CLIP below to CLIP above the textured ground."""
LIFT = 1e-4
"""m, height of the textured copy above z = 0 (above a World's own ground plane, which TinyRenderer also draws)."""


class CameraGround:
    """The textured ground in a PyBullet client, rendered by its TinyRenderer camera; a drop-in for
    ``GroundTexture.patches``."""

    def __init__(self, world_client: int, texture: GroundTexture, tiles: int = 3):
        """Add ``tiles`` x ``tiles`` copies of ``texture``'s tile (odd ``tiles``, centred on the origin) to the
        client, visual only (no mass, no collision)."""
        if isinstance(tiles, bool) or not isinstance(tiles, int) or tiles < 1 or tiles % 2 == 0:
            raise ValueError(f"tiles must be an odd integer >= 1, got {tiles!r}")
        self.client, self.texture, self.tiles = world_client, texture, tiles
        c = world_client
        length, width = texture.extent
        self._extent = np.array([length, width])
        fd, path = tempfile.mkstemp(suffix=".png")
        os.close(fd)
        try:
            cv2.imwrite(path, np.round(np.clip(texture.image, 0, 1) * 255).astype(np.uint8))
            self.texture_id = pb.loadTexture(path, physicsClientId=c)
        finally:
            os.remove(path)
        vertices, indices, uvs = [], [], []
        for i in range(tiles):
            for j in range(tiles):
                x0 = (i - (tiles - 1) / 2 - 0.5) * length
                y0 = (j - (tiles - 1) / 2 - 0.5) * width
                k = len(vertices)
                vertices += [[x0, y0, LIFT], [x0 + length, y0, LIFT], [x0 + length, y0 + width, LIFT],
                             [x0, y0 + width, LIFT]]
                uvs += [[0, 1], [1, 1], [1, 0], [0, 0]]  # TinyRenderer's v runs up from the image's last row
                indices += [k, k + 1, k + 2, k, k + 2, k + 3]  # counter-clockwise seen from above
        shape = pb.createVisualShape(pb.GEOM_MESH, vertices=vertices, indices=indices, uvs=uvs,
                                     normals=[[0, 0, 1]] * len(vertices), physicsClientId=c)
        self.body = pb.createMultiBody(baseMass=0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=shape,
                                       physicsClientId=c)
        pb.changeVisualShape(self.body, -1, textureUniqueId=self.texture_id, rgbaColor=[1, 1, 1, 1],
                             physicsClientId=c)

    def patches(self, affines: np.ndarray, size_px: int) -> np.ndarray:
        """(N, size_px, size_px) float32 images in [0, 1], one camera image per view; ``affines`` as in
        ``GroundTexture.patches``. A view whose affine is singular (a sensor that sees no ground) is mid-grey."""
        affines = np.asarray(affines, dtype=float).reshape(-1, 2, 3)
        out = np.full((len(affines), size_px, size_px), 0.5, dtype=np.float32)
        for n, affine in enumerate(affines):
            out[n] = self._render(affine, size_px)
        return out

    def _render(self, affine: np.ndarray, size_px: int, near: float = EYE_HEIGHT - CLIP,
                far: float = EYE_HEIGHT + CLIP) -> np.ndarray:
        linear = affine[:, :2]
        det = np.linalg.det(linear)
        if not math.isfinite(det) or abs(det) < 1e-18:
            return np.full((size_px, size_px), 0.5, dtype=np.float32)
        # Centre on the pixel grid TinyRenderer samples (half a pixel off), then wrap into the middle tile.
        centre = affine[:, 2] + linear @ np.array([0.5, -0.5])
        centre = (centre + self._extent / 2) % self._extent - self._extent / 2
        reach = np.abs(linear).sum(axis=1) * size_px / 2  # m, half the footprint's bounding box along x and y
        if np.any(reach > (self.tiles - 1) / 2 * self._extent + 1e-12):
            raise ValueError(f"a {size_px} px patch reaches {reach} m from its centre, beyond the {self.tiles} x "
                             f"{self.tiles} tiles of {self._extent} m: use more tiles")
        inverse = np.linalg.inv(linear)  # ground offset -> (u, v) px
        view = np.zeros((4, 4))
        # Eye coordinates: x = 2 u / size (normalised device x at unit depth), y = -2 v / size (screen y up,
        # image rows down), z = height above the ground minus the eye height.
        view[0, :2] = 2 / size_px * inverse[0]
        view[1, :2] = -2 / size_px * inverse[1]
        view[:2, 3] = -view[:2, :2] @ centre
        view[2, 2], view[2, 3] = 1.0, -(EYE_HEIGHT + LIFT)
        view[3, 3] = 1.0
        projection = np.array([
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, -(far + near) / (far - near), -2 * far * near / (far - near)],
            [0.0, 0.0, -1.0, 0.0],
        ])
        _, _, rgba, _, _ = pb.getCameraImage(
            size_px, size_px, viewMatrix=view.T.ravel().tolist(), projectionMatrix=projection.T.ravel().tolist(),
            renderer=pb.ER_TINY_RENDERER, shadow=0, lightAmbientCoeff=1.0, lightDiffuseCoeff=0.0,
            lightSpecularCoeff=0.0, flags=pb.ER_NO_SEGMENTATION_MASK, physicsClientId=self.client)
        red = np.asarray(rgba, dtype=np.uint8).reshape(size_px, size_px, 4)[:, :, 0]
        return red.astype(np.float32) / np.float32(255)
