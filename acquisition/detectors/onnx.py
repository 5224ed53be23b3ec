"""Top-down ONNX pose models (RTMPose / HRNet style exports) through onnxruntime.

The model takes (N, 3, H, W) float32 normalised RGB crops and returns either
- SimCC vectors: two outputs (N, J, W * r) and (N, J, H * r) (RTMPose; ``r`` = split ratio, usually 2),
- or heatmaps: one output (N, J, h, w) (HRNet, SimpleBaseline), with ``h, w`` = input size / stride.
The decoder is picked from the output shapes. J = 17 is COCO-17, J = 26 is Halpe-26 (or give the
skeleton). Person boxes come from the caller (``detect(..., boxes_xyxy_px=...)``), else from MediaPipe's
pose tracker (``person_detector=True``: the boxes of MediaPipe Pose lite's landmarks), else the whole image is one
box. Keypoints are mapped back through the crop's affine transform.
"""

from __future__ import annotations

import logging
from abc import ABC, abstractmethod
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from gaitcap.acquisition.detectors.base import DetectorConfig, check_image, empty_keypoints, register_detector
from gaitcap.acquisition.detectors.crops import Crop, box_crop
from gaitcap.reconstruction.skeletons import Skeleton, get_skeleton

log = logging.getLogger(__name__)

SKELETON_BY_JOINT_COUNT = {17: "coco17", 26: "halpe26", 133: None, 136: "halpe136"}
IMAGENET_MEAN_RGB = (123.675, 116.28, 103.53)
IMAGENET_STD_RGB = (58.395, 57.12, 57.375)


class KeypointDecoder(ABC):
    """Turns raw network outputs into (N, J, 3) keypoints in crop input px (x, y, confidence)."""

    @abstractmethod
    def decode(self, outputs: list[np.ndarray]) -> np.ndarray: ...

    @property
    @abstractmethod
    def num_joints(self) -> int: ...


@dataclass(frozen=True)
class SimccDecoder(KeypointDecoder):
    """SimCC: x = argmax(simcc_x) / ratio, y = argmax(simcc_y) / ratio, confidence = min of both maxima.
    ``y_first``: the model lists simcc_y before simcc_x."""

    joints: int
    split_ratio: float
    y_first: bool = False

    @property
    def num_joints(self) -> int:
        return self.joints

    def decode(self, outputs: list[np.ndarray]) -> np.ndarray:
        simcc_x, simcc_y = outputs[:2][::-1] if self.y_first else outputs[:2]
        x = np.argmax(simcc_x, axis=-1) / self.split_ratio
        y = np.argmax(simcc_y, axis=-1) / self.split_ratio
        conf = np.minimum(simcc_x.max(axis=-1), simcc_y.max(axis=-1))
        return np.stack([x, y, np.clip(conf, 0.0, 1.0)], axis=-1)


@dataclass(frozen=True)
class HeatmapDecoder(KeypointDecoder):
    """Heatmaps: argmax, a quarter-pixel shift towards the larger neighbour, times the stride."""

    joints: int
    stride_xy: tuple[float, float]

    @property
    def num_joints(self) -> int:
        return self.joints

    def decode(self, outputs: list[np.ndarray]) -> np.ndarray:
        (heat,) = outputs
        n, j, h, w = heat.shape
        flat = heat.reshape(n, j, h * w)
        idx = np.argmax(flat, axis=-1)
        conf = flat.max(axis=-1)
        ys, xs = np.divmod(idx, w)
        xf, yf = xs.astype(np.float64), ys.astype(np.float64)
        ni, ji = np.indices((n, j))
        inner_x = (xs > 0) & (xs < w - 1)
        inner_y = (ys > 0) & (ys < h - 1)
        dx = heat[ni, ji, ys, np.clip(xs + 1, 0, w - 1)] - heat[ni, ji, ys, np.clip(xs - 1, 0, w - 1)]
        dy = heat[ni, ji, np.clip(ys + 1, 0, h - 1), xs] - heat[ni, ji, np.clip(ys - 1, 0, h - 1), xs]
        xf += np.where(inner_x, 0.25 * np.sign(dx), 0.0)
        yf += np.where(inner_y, 0.25 * np.sign(dy), 0.0)
        return np.stack([xf * self.stride_xy[0], yf * self.stride_xy[1], np.clip(conf, 0.0, 1.0)], axis=-1)


def decoder_for(output_shapes: list[tuple], input_size_px: tuple[int, int]) -> KeypointDecoder:
    """Pick the decoder from the model's output shapes; ValueError explaining what was expected."""
    w, h = input_size_px
    if len(output_shapes) >= 2 and len(output_shapes[0]) == 3 and len(output_shapes[1]) == 3:
        jx, lx = output_shapes[0][1:]
        jy, ly = output_shapes[1][1:]
        if jx != jy or not isinstance(lx, int) or not isinstance(ly, int):
            raise ValueError(f"ONNX model: SimCC outputs disagree or are dynamic: {output_shapes[:2]}")
        if abs(lx / w - ly / h) < 1e-6:
            return SimccDecoder(joints=int(jx), split_ratio=lx / w)
        if abs(ly / w - lx / h) < 1e-6:  # simcc_y listed first
            return SimccDecoder(joints=int(jx), split_ratio=ly / w, y_first=True)
        raise ValueError(f"ONNX model: SimCC lengths {lx}, {ly} do not match input {w}x{h} by one ratio")
    if len(output_shapes[0]) == 4:
        _, j, hh, hw = output_shapes[0]
        if not isinstance(hh, int) or not isinstance(hw, int):
            raise ValueError(f"ONNX model: heatmap output has dynamic size {output_shapes[0]}")
        return HeatmapDecoder(joints=int(j), stride_xy=(w / hw, h / hh))
    raise ValueError(
        "ONNX model: expected SimCC outputs (N, J, Wx), (N, J, Hy) or heatmaps (N, J, h, w), "
        f"got output shapes {output_shapes}"
    )


@register_detector
@dataclass(frozen=True)
class OnnxConfig(DetectorConfig):
    """A top-down ONNX pose model at ``model_path``.

    Attributes:
        model_path: the .onnx file.
        skeleton: skeleton name; None infers it from the joint count (17 -> coco17, 26 -> halpe26).
        box_padding: person boxes are enlarged by this factor before cropping.
        mean_rgb, std_rgb: input normalisation (ImageNet by default, as RTMPose and HRNet).
        num_threads: onnxruntime intra-op threads (0 = its default).
        device: "auto" (onnxruntime's CUDA provider when it has one, else the CPU, said in the log), "cuda"
            (the CUDA provider or an error naming the providers there are) or "cpu".
        person_detector: when no boxes are given, find people with MediaPipe Pose (lite model, tracked
            per camera) and crop around their landmarks.
        max_people: at most this many people from MediaPipe (default 4: everyone in view).
        person_min_score: MediaPipe's person detector score threshold.
    """

    kind = "onnx"
    model_path: Path
    skeleton: str | None = None
    box_padding: float = 1.25
    mean_rgb: tuple[float, float, float] = IMAGENET_MEAN_RGB
    std_rgb: tuple[float, float, float] = IMAGENET_STD_RGB
    num_threads: int = 0
    device: str = "auto"
    person_detector: bool = False
    max_people: int = 4
    person_min_score: float = 0.5

    def build(self) -> OnnxDetector:
        return OnnxDetector(self)


class OnnxDetector:
    """Runs a top-down ONNX pose model on person boxes (or the whole image)."""

    def __init__(self, config: OnnxConfig):
        import onnxruntime as ort

        path = Path(config.model_path)
        if not path.is_file():
            raise FileNotFoundError(f"ONNX model not found: {path}")
        opts = ort.SessionOptions()
        if config.num_threads:
            opts.intra_op_num_threads = config.num_threads
        try:
            self._session = ort.InferenceSession(
                str(path), opts, providers=execution_providers(config.device, ort.get_available_providers()))
        except Exception as exc:  # onnxruntime raises its own exception types
            raise ValueError(f"ONNX model {path}: cannot be loaded: {exc}") from exc
        self.config = config
        self.provider = self._session.get_providers()[0]
        inp = self._session.get_inputs()[0]
        if len(inp.shape) != 4 or inp.shape[1] != 3 or not all(isinstance(v, int) for v in inp.shape[2:]):
            raise ValueError(f"ONNX model {path}: expected an input (N, 3, H, W) with fixed H, W, got {inp.shape}")
        self._input_name = inp.name
        self._fixed_batch = inp.shape[0] if isinstance(inp.shape[0], int) else None
        self.input_size_px = (int(inp.shape[3]), int(inp.shape[2]))
        shapes = [tuple(o.shape) for o in self._session.get_outputs()]
        self._decoder = decoder_for(shapes, self.input_size_px)
        self.skeleton = _skeleton_for(config.skeleton, self._decoder.num_joints, path)
        self._mean = np.asarray(config.mean_rgb, dtype=np.float32)
        self._std = np.asarray(config.std_rgb, dtype=np.float32)
        self._people = None
        if config.person_detector:
            from gaitcap.acquisition.detectors.mediapipe import MediaPipeConfig

            self._people = MediaPipeConfig(
                model="lite", num_poses=config.max_people, min_detection_confidence=config.person_min_score,
                num_threads=max(1, config.num_threads),
            ).build()

    def detect(
        self,
        image_bgr: np.ndarray,
        *,
        camera: str,
        frame_id: int,
        timestamp_ns: int,
        boxes_xyxy_px: np.ndarray | None = None,
    ) -> np.ndarray:
        """(H, W, 3) BGR -> (P, J, 3) keypoints for P person boxes (see the module docstring)."""
        img = check_image(image_bgr, camera=camera)
        return self._keypoints([(img, self._crops(img, camera, frame_id, timestamp_ns, boxes_xyxy_px))])[0]

    def detect_batch(self, images: list[np.ndarray], *, cameras: list[str], frame_ids: list[int],
                     timestamps_ns: list[int]) -> list[np.ndarray]:
        """Several images (of several cameras) in one model run: [(P_i, J, 3)], as :meth:`detect` each."""
        imgs = [check_image(im, camera=c) for im, c in zip(images, cameras, strict=True)]
        return self._keypoints([(im, self._crops(im, c, f, t, None))
                                for im, c, f, t in zip(imgs, cameras, frame_ids, timestamps_ns, strict=True)])

    def _crops(self, img: np.ndarray, camera: str, frame_id: int, timestamp_ns: int, boxes_xyxy_px) -> list[Crop]:
        if boxes_xyxy_px is None and self._people is not None:
            boxes_xyxy_px = self._people.boxes(img, camera=camera, frame_id=frame_id, timestamp_ns=timestamp_ns)
        boxes = _boxes_or_whole_image(boxes_xyxy_px, img.shape, camera=camera)
        return [box_crop(b, out_size_px=self.input_size_px, padding=self.config.box_padding) for b in boxes]

    def _keypoints(self, images_and_crops: list[tuple[np.ndarray, list[Crop]]]) -> list[np.ndarray]:
        """One model run over every crop of every image -> (P_i, J, 3) per image, in image px."""
        patches = [self._preprocess(img, c) for img, crops in images_and_crops for c in crops]
        if not patches:
            return [empty_keypoints(self.skeleton.num_joints) for _ in images_and_crops]
        kp = self._decoder.decode(self._run(np.stack(patches)))
        out, k = [], 0
        for _, crops in images_and_crops:
            people = np.empty((len(crops), *kp.shape[1:]), dtype=np.float64)
            for i, crop in enumerate(crops):
                people[i, :, :2] = crop.to_image(kp[k + i, :, :2])
                people[i, :, 2] = kp[k + i, :, 2]
            out.append(people)
            k += len(crops)
        return out

    def _preprocess(self, img: np.ndarray, crop: Crop) -> np.ndarray:
        patch = crop.warp(img)
        rgb = cv2.cvtColor(patch, cv2.COLOR_BGR2RGB).astype(np.float32)
        return ((rgb - self._mean) / self._std).transpose(2, 0, 1)

    def _run(self, batch: np.ndarray) -> list[np.ndarray]:
        if self._fixed_batch is None or self._fixed_batch == batch.shape[0]:
            return self._session.run(None, {self._input_name: batch})
        parts = [self._session.run(None, {self._input_name: batch[i : i + 1]}) for i in range(batch.shape[0])]
        return [np.concatenate([p[k] for p in parts]) for k in range(len(parts[0]))]


DEVICE_PROVIDERS = {"cuda": "CUDAExecutionProvider", "cpu": "CPUExecutionProvider"}


def execution_providers(device: str, available: list[str]) -> list[str]:
    """onnxruntime providers for ``device`` (auto | cuda | cpu) given the ``available`` ones; "auto" without
    CUDA logs the CPU fallback; "cuda" without it is a ValueError naming what there is."""
    if device not in ("auto", *DEVICE_PROVIDERS):
        raise ValueError(f"onnx device must be auto, cuda or cpu, got {device!r}")
    cuda, cpu = DEVICE_PROVIDERS["cuda"], DEVICE_PROVIDERS["cpu"]
    if device == "cpu":
        return [cpu]
    if cuda in available:
        log.info("onnx: running on %s (GPU), %s as fallback", cuda, cpu)
        return [cuda, cpu]
    if device == "cuda":
        raise ValueError(f"onnx device cuda: onnxruntime has no {cuda} here (it has {available})")
    log.warning("onnx: no GPU provider (%s not in onnxruntime's %s): running on the CPU fallback, %s", cuda,
                available, cpu)
    return [cpu]


def _skeleton_for(name: str | None, joints: int, path: Path) -> Skeleton:
    if name is not None:
        skel = get_skeleton(name)
        if skel.num_joints != joints:
            raise ValueError(f"ONNX model {path}: outputs {joints} joints but skeleton {name} has {skel.num_joints}")
        return skel
    inferred = SKELETON_BY_JOINT_COUNT.get(joints)
    if inferred is None:
        raise ValueError(f"ONNX model {path}: {joints} joints; give the skeleton name (known: 17, 26, 136)")
    return get_skeleton(inferred)


def _boxes_or_whole_image(boxes: np.ndarray | None, shape: tuple, *, camera: str) -> np.ndarray:
    h, w = shape[:2]
    if boxes is None:
        return np.array([[0.0, 0.0, float(w), float(h)]])
    arr = np.asarray(boxes, dtype=np.float64).reshape(-1, 4) if np.size(boxes) else np.zeros((0, 4))
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"camera {camera}: person boxes must be finite x0, y0, x1, y1 px")
    return arr
