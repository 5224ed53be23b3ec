"""Where a worker computes: the completion detection (the batched ONNX model, onnxruntime's execution
provider) and the JAX fits (a JAX device), chosen once at the worker's start and said plainly in its log.

``gaitcap worker --gpu``: both on the GPU, or a refusal naming what this host lacks (onnxruntime's providers,
JAX's devices); ``--gpu --gpu-fallback``: the CPU where the GPU is missing, said as a warning. Without
``--gpu`` the worker runs as it always has (onnxruntime's ``auto`` choice, JAX's default device) and says
which those are.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

log = logging.getLogger(__name__)

CUDA_PROVIDER, CPU_PROVIDER = "CUDAExecutionProvider", "CPUExecutionProvider"
GPU_PLATFORMS = ("cuda", "rocm", "gpu")


@dataclass(frozen=True)
class DeviceChoice:
    """``gpu``: run on the GPU; ``fallback``: where it is missing, run on the CPU (else refuse)."""

    gpu: bool = False
    fallback: bool = False


@dataclass(frozen=True)
class DevicePlan:
    """What runs where: ``onnx_device`` the ONNX detector's device (cuda | cpu | auto), ``onnx_provider``
    the provider it will use, ``jax_device`` the JAX device of the fits (e.g. 'cuda:0', 'cpu:0'),
    ``notes`` fallbacks taken (said as warnings)."""

    onnx_device: str
    onnx_provider: str
    jax_device: str
    notes: tuple[str, ...] = ()

    def lines(self, completion: str | None) -> list[str]:
        """What the worker says at start: each computation and its device."""
        detection = ("no completion detection (--complete-with none)" if completion is None else
                     f"completion detection ({completion}) on onnxruntime's {self.onnx_provider}"
                     if completion.startswith("onnx") else
                     f"completion detection ({completion}) on the CPU (it has no GPU path)")
        return [detection, f"JAX fits on device {self.jax_device}", *self.notes]


def _jax_name(device) -> str:
    return f"{device.platform}:{device.id}"


def plan_devices(choice: DeviceChoice, *, providers: list[str], jax_devices: list) -> DevicePlan:
    """The plan for ``choice`` on a host whose onnxruntime has ``providers`` and whose JAX has
    ``jax_devices`` (``jax.devices()``: JAX's default backend's devices, the GPU's where JAX has one). ValueError
    naming what is missing when the GPU is asked for without ``fallback``."""
    gpus = [d for d in jax_devices if d.platform in GPU_PLATFORMS]
    has_cuda = CUDA_PROVIDER in providers
    if not choice.gpu:
        return DevicePlan("auto", CUDA_PROVIDER if has_cuda else CPU_PROVIDER, _jax_name(jax_devices[0]))
    missing = ([] if has_cuda else [f"onnxruntime has no {CUDA_PROVIDER} (its providers: {', '.join(providers)}; "
                                    "install onnxruntime-gpu)"]) + \
              ([] if gpus else [f"JAX has no GPU device (its devices: "
                                f"{', '.join(_jax_name(d) for d in jax_devices)}; install jax[cuda12])"])
    if missing and not choice.fallback:
        raise ValueError("--gpu: this host cannot run the worker on a GPU: " + "; ".join(missing)
                         + " (--gpu-fallback runs what lacks a GPU on the CPU)")
    notes = tuple(f"--gpu-fallback: {m}: on the CPU instead" for m in missing)
    cpu = next(d for d in jax_devices if d.platform == "cpu") if not gpus else None
    return DevicePlan("cuda" if has_cuda else "cpu", CUDA_PROVIDER if has_cuda else CPU_PROVIDER,
                      _jax_name(gpus[0] if gpus else cpu), notes)


def host_plan(choice: DeviceChoice) -> DevicePlan:
    """:func:`plan_devices` on this host's onnxruntime and JAX."""
    import jax
    import onnxruntime as ort

    devices = list(jax.devices())
    if choice.gpu and not any(d.platform in GPU_PLATFORMS for d in devices):
        devices += [d for d in jax.devices("cpu") if d not in devices]
    return plan_devices(choice, providers=list(ort.get_available_providers()), jax_devices=devices)


def apply_plan(plan: DevicePlan, completion, choice: DeviceChoice = DeviceChoice()):
    """Make this process follow ``plan``: JAX's default device set to the plan's; the completion settings
    (None or :class:`~gaitcap.services.processing.completion.CompletionSettings`) with the ONNX detector's
    device set. Returns the completion settings to use. ``choice.gpu`` with a completion detector that has
    no GPU path (MediaPipe) is refused unless ``choice.fallback``."""
    import jax

    if choice.gpu and completion is not None and not hasattr(completion.detector, "device") and not choice.fallback:
        raise ValueError(f"--gpu: the completion detector {completion.detector.kind} has no GPU path (use "
                         "--complete-with onnx, or --gpu-fallback to run it on the CPU)")

    platform, _, index = plan.jax_device.partition(":")
    device = next(d for d in jax.devices(platform) if d.id == int(index))
    jax.config.update("jax_default_device", device)
    if completion is None or not hasattr(completion.detector, "device"):
        return completion
    return replace(completion, detector=replace(completion.detector, device=plan.onnx_device))
