"""The ONNX top-down detector on small graphs built here, whose answer is known.

The "blob" graphs find the brightest spot of the crop (SimCC: max over rows / columns; heatmap: a
strided sample), so the whole chain is checked: box -> padded crop -> normalisation -> model ->
decoding -> inverse affine back to image px.
"""

import cv2
import numpy as np
import onnx
import pytest
from gaitcap.acquisition.detectors.base import DETECTOR_CONFIGS, Detector
from gaitcap.acquisition.detectors.crops import box_crop
from gaitcap.acquisition.detectors.onnx import OnnxConfig, SimccDecoder
from gaitcap.acquisition.installed import share_path
from onnx import TensorProto, helper

H, W = 128, 96  # network input (RTMPose's 256x192 halved)


def _save(tmp_path, nodes, outputs, inits=(), name="m.onnx", batch="N"):
    inp = helper.make_tensor_value_info("input", TensorProto.FLOAT, [batch, 3, H, W])
    graph = helper.make_graph(nodes, "g", [inp], outputs, initializer=list(inits))
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 18)], ir_version=9)
    onnx.checker.check_model(model)
    path = tmp_path / name
    onnx.save(model, str(path))
    return path


def _i64(name, values):
    return helper.make_tensor(name, TensorProto.INT64, [len(values)], list(values))


def simcc_blob_model(tmp_path, joints=26, ratio=2, batch="N", swapped=False):
    """simcc_x[n, j, r*col + k] = max over rows of the channel sum at column col (same for y)."""
    nodes = [
        helper.make_node("ReduceSum", ["input", "ax1"], ["gray"], keepdims=1),  # (N,1,H,W)
        helper.make_node("ReduceMax", ["gray", "ax2"], ["colmax"], keepdims=1),  # (N,1,1,W)
        helper.make_node("ReduceMax", ["gray", "ax3"], ["rowmax"], keepdims=1),  # (N,1,H,1)
        helper.make_node("Reshape", ["colmax", "shape_c"], ["c4"]),  # (N,1,W,1)
        helper.make_node("Reshape", ["rowmax", "shape_r"], ["r4"]),  # (N,1,H,1)
        helper.make_node("Expand", ["c4", "rep_c"], ["ce"]),  # (N,J,W,ratio)
        helper.make_node("Expand", ["r4", "rep_r"], ["re"]),
        helper.make_node("Reshape", ["ce", "out_c"], ["simcc_x"]),
        helper.make_node("Reshape", ["re", "out_r"], ["simcc_y"]),
    ]
    inits = [
        _i64("ax1", [1]), _i64("ax2", [2]), _i64("ax3", [3]),
        _i64("shape_c", [0, 1, W, 1]), _i64("shape_r", [0, 1, H, 1]),
        _i64("rep_c", [1, joints, W, ratio]), _i64("rep_r", [1, joints, H, ratio]),
        _i64("out_c", [0, joints, W * ratio]), _i64("out_r", [0, joints, H * ratio]),
    ]
    outs = [
        helper.make_tensor_value_info("simcc_x", TensorProto.FLOAT, [batch, joints, W * ratio]),
        helper.make_tensor_value_info("simcc_y", TensorProto.FLOAT, [batch, joints, H * ratio]),
    ]
    if swapped:
        outs = outs[::-1]
    return _save(tmp_path, nodes, outs, inits, name=f"simcc{joints}_{batch}_{swapped}.onnx", batch=batch)


def heatmap_blob_model(tmp_path, joints=17, stride=4):
    """heatmap[n, j, i, k] = channel sum at crop px (stride*k, stride*i)."""
    nodes = [
        helper.make_node("ReduceSum", ["input", "ax1"], ["gray"], keepdims=1),
        helper.make_node("Slice", ["gray", "starts", "ends", "axes", "steps"], ["sub"]),
        helper.make_node("Expand", ["sub", "rep"], ["heatmaps"]),
    ]
    inits = [
        _i64("ax1", [1]), _i64("starts", [0, 0]), _i64("ends", [H, W]), _i64("axes", [2, 3]),
        _i64("steps", [stride, stride]), _i64("rep", [1, joints, 1, 1]),
    ]
    outs = [helper.make_tensor_value_info("heatmaps", TensorProto.FLOAT, ["N", joints, H // stride, W // stride])]
    return _save(tmp_path, nodes, outs, inits, name=f"heat{joints}.onnx")


def constant_simcc_model(tmp_path, argmax_x, argmax_y, ratio=2):
    """Per-joint SimCC vectors with known argmax (input only multiplied by 0 and added)."""
    j = len(argmax_x)
    sx = np.zeros((1, j, W * ratio), np.float32)
    sy = np.zeros((1, j, H * ratio), np.float32)
    sx[0, np.arange(j), argmax_x] = 0.9
    sy[0, np.arange(j), argmax_y] = 0.7
    nodes = [
        helper.make_node("ReduceSum", ["input", "ax"], ["s"], keepdims=0),  # (N,)
        helper.make_node("Mul", ["s", "zero"], ["z"]),
        helper.make_node("Reshape", ["z", "sh"], ["z3"]),  # (N,1,1)
        helper.make_node("Add", ["z3", "cx"], ["simcc_x"]),
        helper.make_node("Add", ["z3", "cy"], ["simcc_y"]),
    ]
    inits = [
        _i64("ax", [1, 2, 3]), helper.make_tensor("zero", TensorProto.FLOAT, [], [0.0]), _i64("sh", [-1, 1, 1]),
        onnx.numpy_helper.from_array(sx, "cx"), onnx.numpy_helper.from_array(sy, "cy"),
    ]
    outs = [
        helper.make_tensor_value_info("simcc_x", TensorProto.FLOAT, ["N", j, W * ratio]),
        helper.make_tensor_value_info("simcc_y", TensorProto.FLOAT, ["N", j, H * ratio]),
    ]
    return _save(tmp_path, nodes, outs, inits, name="const.onnx")


def _image_with_blob(center_xy, size=(640, 480), sigma=4.0):
    w, h = size
    yy, xx = np.mgrid[0:h, 0:w]
    g = np.exp(-((xx - center_xy[0]) ** 2 + (yy - center_xy[1]) ** 2) / (2 * sigma**2))
    return np.repeat((255 * g).astype(np.uint8)[:, :, None], 3, axis=2)


def _detect(det, img, boxes=None):
    return det.detect(img, camera="cam0", frame_id=0, timestamp_ns=0, boxes_xyxy_px=boxes)


def test_registry_knows_onnx():
    assert DETECTOR_CONFIGS["onnx"] is OnnxConfig


def test_simcc_blob_found_in_image_px_through_boxes(tmp_path):
    det = OnnxConfig(model_path=simcc_blob_model(tmp_path)).build()
    assert isinstance(det, Detector)
    assert det.skeleton.name == "halpe26" and det.input_size_px == (W, H)
    blobs = [(200.0, 150.0), (470.0, 330.0)]
    img = np.maximum(_image_with_blob(blobs[0]), _image_with_blob(blobs[1]))
    # Boxes about 200 px tall -> crop scale about 2 image px per crop px; each box holds one blob.
    boxes = np.array([[140, 60, 250, 260], [400, 250, 520, 450]], float)
    kp = _detect(det, img, boxes)
    assert kp.shape == (2, 26, 3)
    scale = 200 * 1.25 / H
    for p, (bx, by) in enumerate(blobs):
        np.testing.assert_allclose(kp[p, :, 0], bx, atol=1.0 * scale)
        np.testing.assert_allclose(kp[p, :, 1], by, atol=1.0 * scale)
    assert np.all(kp[..., 2] == 1.0)  # bright blob -> confidence clipped to 1


@pytest.mark.parametrize(("batch", "swapped"), [(1, False), ("N", True)])
def test_fixed_batch_and_output_order(tmp_path, batch, swapped):
    # A batch-1 export runs box by box; y-before-x outputs are told apart by their lengths (H != W).
    det = OnnxConfig(model_path=simcc_blob_model(tmp_path, joints=17, batch=batch, swapped=swapped)).build()
    blobs = [(200.0, 150.0), (470.0, 330.0)]
    img = np.maximum(_image_with_blob(blobs[0]), _image_with_blob(blobs[1]))
    kp = _detect(det, img, np.array([[140, 60, 250, 260], [400, 250, 520, 450]], float))
    scale = 200 * 1.25 / H
    np.testing.assert_allclose(kp[:, 0, :2], blobs, atol=scale)


def test_heatmap_blob_found_in_image_px(tmp_path):
    det = OnnxConfig(model_path=heatmap_blob_model(tmp_path)).build()
    assert det.skeleton.name == "coco17"
    img = _image_with_blob((333.0, 222.0), sigma=6.0)
    kp = _detect(det, img, np.array([[280, 120, 380, 320]], float))
    scale = 200 * 1.25 / H
    assert kp.shape == (1, 17, 3)
    # Heatmap stride 4: within half a stride (plus a pixel) of the blob, in crop px times the scale.
    np.testing.assert_allclose(kp[0, :, 0], 333.0, atol=3.0 * scale)
    np.testing.assert_allclose(kp[0, :, 1], 222.0, atol=3.0 * scale)


def test_whole_image_when_no_boxes(tmp_path):
    det = OnnxConfig(model_path=simcc_blob_model(tmp_path, joints=17)).build()
    img = _image_with_blob((100.0, 400.0), sigma=6.0)
    kp = _detect(det, img)
    # Whole 640x480 image padded 1.25 and to the 3:4 aspect -> 800 px wide / 96 px.
    scale = 640 * 1.25 / W
    assert kp.shape == (1, 17, 3)
    np.testing.assert_allclose(kp[0, :, :2], np.tile([100.0, 400.0], (17, 1)), atol=scale)


def test_per_joint_decoding_matches_affine_map(tmp_path):
    rng = np.random.default_rng(0)
    ax = rng.integers(0, W * 2, 17)
    ay = rng.integers(0, H * 2, 17)
    det = OnnxConfig(model_path=constant_simcc_model(tmp_path, ax, ay), box_padding=1.0).build()
    box = np.array([[100.0, 50.0, 196.0, 306.0]])  # 96 x 256 -> aspect 3:8, widened to 192 x 256
    kp = _detect(det, np.zeros((480, 640, 3), np.uint8), box)
    sx = sy = 256 / H
    np.testing.assert_allclose(kp[0, :, 0], 148.0 + (ax / 2 - W / 2) * sx, atol=1e-3)
    np.testing.assert_allclose(kp[0, :, 1], 178.0 + (ay / 2 - H / 2) * sy, atol=1e-3)
    np.testing.assert_allclose(kp[0, :, 2], 0.7)  # min of the two maxima


def test_simcc_decoder_confidence_is_min_of_maxima():
    sx = np.zeros((1, 2, 8))
    sy = np.zeros((1, 2, 6))
    sx[0, 0, 5], sy[0, 0, 2] = 0.3, 0.8
    sx[0, 1, 1], sy[0, 1, 4] = 1.7, 1.2
    kp = SimccDecoder(joints=2, split_ratio=2.0).decode([sx, sy])
    np.testing.assert_allclose(kp[0], [[2.5, 1.0, 0.3], [0.5, 2.0, 1.0]])


def test_no_boxes_no_people(tmp_path):
    det = OnnxConfig(model_path=simcc_blob_model(tmp_path)).build()
    kp = _detect(det, np.zeros((48, 64, 3), np.uint8), np.zeros((0, 4)))
    assert kp.shape == (0, 26, 3)


def test_bad_inputs_are_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="missing.onnx"):
        OnnxConfig(model_path=tmp_path / "missing.onnx").build()
    path = simcc_blob_model(tmp_path, joints=17)
    with pytest.raises(ValueError, match="skeleton halpe26 has 26"):
        OnnxConfig(model_path=path, skeleton="halpe26").build()
    det = OnnxConfig(model_path=path).build()
    with pytest.raises(ValueError, match="camera cam0"):
        _detect(det, np.zeros((48, 64), np.float32))
    with pytest.raises(ValueError, match="x1 > x0"):
        _detect(det, np.zeros((48, 64, 3), np.uint8), np.array([[10, 10, 5, 20]]))
    garbage = tmp_path / "garbage.onnx"
    garbage.write_bytes(b"not a model")
    with pytest.raises(ValueError, match="cannot be loaded"):
        OnnxConfig(model_path=garbage).build()


def test_rgb_order_and_normalisation(tmp_path):
    # The network gets RGB: channel 0 is brightest at the red spot, channel 2 at the blue one.
    det = OnnxConfig(model_path=simcc_blob_model(tmp_path, joints=17)).build()
    img = np.zeros((480, 640, 3), np.uint8)
    cv2.circle(img, (300, 200), 6, (255, 0, 0), -1)  # blue in BGR
    cv2.circle(img, (500, 100), 6, (0, 0, 255), -1)  # red in BGR
    rgb = det._preprocess(img, box_crop(np.array([0, 0, 640, 480]), out_size_px=(W, H), padding=1.0))
    r_y, r_x = np.unravel_index(np.argmax(rgb[0]), rgb[0].shape)
    b_y, b_x = np.unravel_index(np.argmax(rgb[2]), rgb[2].shape)
    assert r_x > b_x and r_y < b_y
    assert rgb[0].min() == pytest.approx(-123.675 / 58.395, rel=1e-5)


def test_person_detector_places_the_crop_on_the_person(tmp_path):
    from gaitcap.acquisition.detectors.mediapipe import DETECTOR_FILE, MediaPipeConfig, default_model_dir

    video = share_path("testdata", "sports2d-demo.mp4")
    if not (default_model_dir() / DETECTOR_FILE).is_file() or not video.is_file():
        pytest.skip("MediaPipe models / test video not installed (run deploy/bootstrap.sh)")
    cap = cv2.VideoCapture(str(video))
    cap.set(cv2.CAP_PROP_POS_FRAMES, 120)
    ok, frame = cap.read()
    assert ok
    # Every joint at the crop's centre -> the keypoints land on the centre of the person box.
    model = constant_simcc_model(tmp_path, np.full(17, W), np.full(17, H))
    det = OnnxConfig(model_path=model, person_detector=True).build()
    kp = _detect(det, frame)
    box = MediaPipeConfig(model="lite").build().boxes(frame, camera="x", frame_id=0, timestamp_ns=0)[0]
    assert kp.shape == (1, 17, 3)
    np.testing.assert_allclose(kp[0, :, 0], (box[0] + box[2]) / 2, atol=1e-3)
    np.testing.assert_allclose(kp[0, :, 1], (box[1] + box[3]) / 2, atol=1e-3)
    # The walker's hips are at about x 820, y 720 in this frame (1768 x 994), not at the image centre.
    assert abs(kp[0, 0, 0] - 820) < 100 and abs(kp[0, 0, 1] - 720) < 150
    assert _detect(det, np.full((480, 640, 3), 127, np.uint8)).shape == (0, 17, 3)  # nobody, no box


def test_a_batch_of_images_in_one_run_equals_image_by_image(tmp_path):
    det = OnnxConfig(model_path=simcc_blob_model(tmp_path), device="cpu").build()
    imgs = [_image_with_blob((200.0 + 30 * i, 150.0)) for i in range(3)]
    one = [det.detect(im, camera=f"cam{i}", frame_id=i, timestamp_ns=0) for i, im in enumerate(imgs)]
    batch = det.detect_batch(imgs, cameras=["cam0", "cam1", "cam2"], frame_ids=[0, 1, 2], timestamps_ns=[0, 0, 0])
    assert len(batch) == 3
    for a, b in zip(one, batch, strict=True):
        np.testing.assert_allclose(a, b, atol=1e-9)


def test_without_a_gpu_the_cpu_fallback_is_named_in_the_log(tmp_path, caplog):
    import logging

    from gaitcap.acquisition.detectors.onnx import execution_providers

    with caplog.at_level(logging.WARNING, logger="gaitcap.acquisition.detectors.onnx"):
        det = OnnxConfig(model_path=simcc_blob_model(tmp_path)).build()  # device auto; this machine: no CUDA
    if "CUDAExecutionProvider" in __import__("onnxruntime").get_available_providers():
        pytest.skip("this machine has onnxruntime's CUDA provider")
    assert det.provider == "CPUExecutionProvider"
    assert "running on the CPU fallback, CPUExecutionProvider" in caplog.text
    assert execution_providers("auto", ["CUDAExecutionProvider", "CPUExecutionProvider"])[0] == "CUDAExecutionProvider"
    with pytest.raises(ValueError, match="onnx device cuda: onnxruntime has no CUDAExecutionProvider here"):
        execution_providers("cuda", ["CPUExecutionProvider"])
    with pytest.raises(ValueError, match="onnx device must be auto, cuda or cpu, got 'tpu'"):
        execution_providers("tpu", [])
