"""Where the worker computes (``gaitcap worker --gpu``): on this host (no GPU) the plain worker says it runs
the completion detection on onnxruntime's CPU provider and the fits on JAX's CPU device, and does; ``--gpu``
is refused naming what the host lacks (onnxruntime's providers, JAX's devices); ``--gpu --gpu-fallback`` runs
on the CPU saying why; a detector without a GPU path is refused under ``--gpu``. The GPU path itself is
only planned here (a host that has CUDA gets the CUDA provider and JAX's GPU device): no GPU to run it on."""

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import pytest
from gaitcap.acquisition.detectors.mediapipe import MediaPipeConfig
from gaitcap.acquisition.detectors.onnx import OnnxConfig
from gaitcap.services.cli import app
from gaitcap.services.processing.completion import CompletionSettings
from gaitcap.services.processing.devices import DeviceChoice, DevicePlan, apply_plan, host_plan, plan_devices
from typer.testing import CliRunner


@dataclass(frozen=True)
class _Device:  # a JAX device as plan_devices reads it (platform, id): another host's, for the plan only
    platform: str
    id: int


def test_without_gpu_the_worker_says_and_uses_the_cpu():
    plan = host_plan(DeviceChoice())
    assert plan == DevicePlan("auto", "CPUExecutionProvider", "cpu:0")
    onnx = CompletionSettings(OnnxConfig(model_path="model.onnx"), workers=0)
    kept = apply_plan(plan, onnx)
    assert kept.detector.device == "auto" and apply_plan(plan, None) is None
    assert jnp.ones(3).devices() == {jax.devices("cpu")[0]}  # the fits' arrays are on the plan's device
    assert plan.lines(kept.detector_name) == [
        "completion detection (onnx) on onnxruntime's CPUExecutionProvider",
        "JAX fits on device cpu:0"]
    assert plan.lines(None)[0] == "no completion detection (--complete-with none)"


def test_gpu_is_refused_on_a_host_without_one_and_falls_back_only_when_asked(tmp_path):
    with pytest.raises(ValueError, match=r"--gpu: this host cannot run the worker on a GPU: onnxruntime has no "
                                         r"CUDAExecutionProvider \(its providers: .*CPUExecutionProvider.*\); JAX "
                                         r"has no GPU device \(its devices: cpu:0"):
        host_plan(DeviceChoice(gpu=True))
    fallback = host_plan(DeviceChoice(gpu=True, fallback=True))
    assert (fallback.onnx_device, fallback.onnx_provider, fallback.jax_device) == ("cpu", "CPUExecutionProvider",
                                                                                   "cpu:0")
    assert [n.split(":")[0] for n in fallback.notes] == ["--gpu-fallback"] * 2
    onnx = apply_plan(fallback, CompletionSettings(OnnxConfig(model_path="m.onnx"), workers=0),
                      DeviceChoice(gpu=True, fallback=True))
    assert onnx.detector.device == "cpu"
    with pytest.raises(ValueError, match="completion detector mediapipe has no GPU path"):
        apply_plan(fallback, CompletionSettings(MediaPipeConfig(), workers=0), DeviceChoice(gpu=True))
    res = CliRunner().invoke(app, ["worker", "--gpu", "--no-bus", "--no-warm-up", "--data-dir", str(tmp_path),
                                   "--catalog", str(tmp_path / "catalog.sqlite")])
    assert res.exit_code != 0 and "this host cannot run the worker on a GPU" in res.output, res.output
    assert not (tmp_path / "catalog.sqlite").exists()  # refused before anything was opened


def test_a_host_with_cuda_is_planned_on_the_gpu():
    providers = ["CUDAExecutionProvider", "CPUExecutionProvider"]
    plan = plan_devices(DeviceChoice(gpu=True), providers=providers, jax_devices=[_Device("cuda", 0), _Device("cpu", 0)])
    assert plan == DevicePlan("cuda", "CUDAExecutionProvider", "cuda:0")
    cpu_jax = plan_devices(DeviceChoice(gpu=True, fallback=True), providers=providers, jax_devices=[_Device("cpu", 0)])
    assert (cpu_jax.onnx_device, cpu_jax.jax_device, len(cpu_jax.notes)) == ("cuda", "cpu:0", 1)
