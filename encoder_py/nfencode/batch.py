"""`nfc encode-batch`: encode an asset library (a directory of shapes, or a JSON-lines manifest).

One task per asset, run in this process (`workers=1`, no Ray needed) or on a Ray cluster (a local
one started here, or an existing one joined by address; the extra `nfencode[batch]`). The driver
(this process) owns the output directory:

- `OUTDIR/<name>.nfc` per asset, written atomically (temporary file in OUTDIR, fsync, rename), so
  an interrupted run never leaves a partial `.nfc`;
- `OUTDIR/results.jsonl`, one row per asset (ROW_KEYS plus `options_hash`). Rows are appended as
  assets finish, so an interrupted run keeps what it finished; at the end the file is rewritten
  (atomically) with exactly this run's rows: the assets in input order, then the unusable manifest
  lines and duplicate output names.

Resume: an asset is skipped when its `.nfc` exists, has the recorded size, and the last recorded row
for it has the same `options_hash`: a hash of the options that change the bytes (ENCODE_OPTIONS but
not `device`, which only changes float rounding), the input file's contents and the nfencode version.
A `.conf` of range scans is hashed as the `.conf` itself, not the scans it lists.

Grouping (`group` > 1, for GPUs): assets with identical options are trained several per task as one
batched model (`batch_train.compress_many`); each still gets its own file and row. Assets with a
target are encoded one by one (their searches choose their own widths).

Isolation: every failure of one asset (unreadable or broken file, bad manifest row, bad option, a
crashed worker) becomes an `error` row; the others continue. A failure that the same input bytes and
options always give (the file or an option rejected) is recorded with its hash and reported again by
a rerun without running it; crashes, I/O errors, memory and a missing device are retried. Workers read inputs by path (on a
joined cluster every node must see them at the same path) and return the bytes; only the driver
writes.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tqdm import tqdm

from . import __version__
from .bitstream import read_nfc
from .devices import available_cpus
from .errors import DeviceError, InputError, NfcError
from .io import MESH_EXTENSIONS, SCAN_ALIGNMENT_EXTENSION, split_extension
from .rate import check_targets

RESULTS_NAME = "results.jsonl"
ROW_KEYS = ("input", "output", "status", "bytes", "seconds", "field", "width", "target_bytes", "target_cd", "tries",
            "error")
MANIFEST_SUFFIXES = (".jsonl", ".json")

ENCODE_OPTIONS: dict[str, tuple[type, ...]] = {
    "field": (str,),
    "width": (int,),
    "bits": (int,),
    "frequencies": (int,),
    "frequency_base": (float, int),
    "preset": (str,),
    "epochs": (int, type(None)),
    "seed": (int,),
    "device": (str,),
    "color": (str,),
    "color_width": (int,),
    "color_bits": (int,),
    "color_frequencies": (int,),
    "color_resolution": (int,),
    "color_epochs": (int, type(None)),
    "truncation": (float, int, type(None)),
    "target_bytes": (int, type(None)),
    "target_cd": (float, int, type(None)),
}
"""Per-asset options a manifest row may set (with their JSON types), defaulting to the command line's.
A target (TARGETS), when set, runs that asset's rate search (`nfencode.targets`): `target_bytes` the
best file of at most that many bytes (the width chosen, and on a coloured input the colour width),
`target_cd` the smallest whose estimated Chamfer distance is at most that (the width chosen), so
`width` is not used; at most one target per asset. Every other key is an EncodeConfig field."""

TARGETS = ("target_bytes", "target_cd")

HASHED_OPTIONS = ("field", "width", "bits", "frequencies", "frequency_base", "preset", "epochs", "seed", "color",
                  "color_width", "color_bits", "color_frequencies", "color_resolution", "color_epochs", *TARGETS)
"""The options that determine a file's contents (device and threads change only float rounding)."""


@dataclass(frozen=True)
class Asset:
    """One shape to encode: `input` as given, `name` of its output (`<name>.nfc`), full options."""

    input: str
    name: str
    options: dict[str, Any]


@dataclass
class Plan:
    """What discovery found: assets to consider, and error rows for unusable manifest lines."""

    assets: list[Asset] = field(default_factory=list)
    errors: list[dict[str, Any]] = field(default_factory=list)


def row(input: str, status: str, *, output: str | None = None, bytes: int | None = None, seconds: float = 0.0,
        field: str | None = None, width: int | None = None, options: dict[str, Any] | None = None,
        tries: int | None = None, error: str | None = None, options_hash: str | None = None) -> dict[str, Any]:
    """A results.jsonl row (ROW_KEYS in order, then options_hash): the asset's target from its
    `options` (none where unknown), and `tries`, the encodes its target's search ran."""
    options = options or {}
    return {"input": input, "output": output, "status": status, "bytes": bytes, "seconds": round(seconds, 3),
            "field": field, "width": width, "target_bytes": options.get("target_bytes"),
            "target_cd": options.get("target_cd"), "tries": tries, "error": error, "options_hash": options_hash}


# --- Discovery -------------------------------------------------------------------------------------

def asset_name(path: str | os.PathLike[str]) -> str:
    """Output stem of an input: `bunny.ply.gz` → `bunny`."""
    name = Path(path).name
    if name.lower().endswith(".gz"):
        name = name[:-3]
    return Path(name).stem


def is_shape_file(path: Path) -> bool:
    ext, _ = split_extension(path)
    return path.is_file() and not path.name.startswith(".") and ext in MESH_EXTENSIONS + (SCAN_ALIGNMENT_EXTENSION,)


def _check_types(options: dict[str, Any], where: str) -> None:
    for key, value in options.items():
        if key not in ENCODE_OPTIONS:
            raise InputError(f"{where}: unknown key {key!r} (known: path, name, {', '.join(ENCODE_OPTIONS)})")
        types = ENCODE_OPTIONS[key]
        if not isinstance(value, types) or (isinstance(value, bool) and bool not in types):
            raise InputError(f"{where}: {key} must be {' or '.join('null' if t is type(None) else t.__name__ for t in types)}, "
                             f"got {json.dumps(value)}")


def discover(input_path: str | os.PathLike[str], defaults: dict[str, Any]) -> Plan:
    """The assets of a directory (its shape files, sorted; not recursive) or of a manifest (one JSON
    object per line: `path` (relative to the manifest's directory), optional `name` and any of
    ENCODE_OPTIONS). A missing or unusable INPUT is an InputError; a bad manifest line an error row."""
    src = Path(input_path)
    plan = Plan()
    if src.is_dir():
        entries = [(str(p), asset_name(p), {}) for p in sorted(src.iterdir()) if is_shape_file(p)]
        if not entries:
            raise InputError(f"{src}: no shape files ({', '.join(MESH_EXTENSIONS)}, optionally .gz, or .conf)")
    elif src.is_file():
        if src.suffix.lower() not in MANIFEST_SUFFIXES:
            raise InputError(f"{src}: INPUT must be a directory of shapes or a JSON-lines manifest (.jsonl)")
        try:
            text = src.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            raise InputError(f"{src}: cannot read manifest ({getattr(e, 'strerror', None) or e})") from None
        entries = []
        for number, line in enumerate(text.splitlines(), 1):
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            where = f"{src}:{number}"
            try:
                item = json.loads(line)
                if not isinstance(item, dict):
                    raise InputError(f"{where}: a manifest line must be a JSON object")
                path, name = item.pop("path", None), item.pop("name", None)
                if not isinstance(path, str) or not path:
                    raise InputError(f"{where}: missing \"path\" (a string)")
                if name is not None and (not isinstance(name, str) or not name or Path(name).name != name
                                         or name.startswith(".")):
                    raise InputError(f"{where}: \"name\" must be a plain file name, got {json.dumps(name)}")
                _check_types(item, where)
            except json.JSONDecodeError as e:
                plan.errors.append(row(where, "error", error=f"{where}: not JSON ({e.msg})"))
                continue
            except InputError as e:
                plan.errors.append(row(where, "error", error=e.message))
                continue
            full = Path(path) if Path(path).is_absolute() else src.parent / path
            entries.append((str(full), name or asset_name(full), item))
        if not entries and not plan.errors:
            raise InputError(f"{src}: the manifest lists no shapes")
    else:
        raise InputError(f"{src}: no such file or directory")

    used: dict[str, str] = {}
    for path, name, options in entries:
        if name in used:
            plan.errors.append(row(path, "error", width=None,
                                   error=f"{path}: output name {name}.nfc already used by {used[name]}"))
            continue
        used[name] = path
        merged = {**defaults, **options}
        if any(k in options for k in TARGETS):  # a line's target replaces the command line's
            merged.update({k: options.get(k) for k in TARGETS})
        plan.assets.append(Asset(path, name, merged))
    return plan


# --- Resume ----------------------------------------------------------------------------------------

def options_hash(options: dict[str, Any], input_digest: str) -> str:
    # A target enters the key only when set, so the files of earlier runs (no such option) resume.
    hashed = [k for k in HASHED_OPTIONS if k not in TARGETS or options.get(k) is not None]
    key = {"nfencode": __version__, "input_sha256": input_digest, **{k: options.get(k) for k in hashed}}
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:16]


def file_digest(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def previous_rows(outdir: Path) -> dict[str, dict[str, Any]]:
    """The last row per asset in OUTDIR/results.jsonl with an options hash: a finished one (ok or
    skipped) under its output file name, a final error under "error:" + its input. A torn or
    foreign line (an interrupted write) is ignored."""
    found: dict[str, dict[str, Any]] = {}
    try:
        lines = (outdir / RESULTS_NAME).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError):
        return found
    for line in lines:
        try:
            r = json.loads(line)
        except json.JSONDecodeError:
            continue
        if not isinstance(r, dict) or not r.get("options_hash"):
            continue
        if r.get("status") in ("ok", "skipped") and isinstance(r.get("output"), str):
            found[Path(r["output"]).name] = r
        elif r.get("status") == "error" and isinstance(r.get("input"), str):
            found["error:" + r["input"]] = r
    return found


# --- Files -----------------------------------------------------------------------------------------

def write_atomic(path: Path, data: bytes) -> None:
    """Write `data` to `path` through a temporary file beside it and a rename: readers (and an
    interrupted run) see the old file or the whole new one, never a partial one."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


# --- One asset -------------------------------------------------------------------------------------

def _targeted(options: dict[str, Any]) -> bool:
    return any(options.get(k) is not None for k in TARGETS)


def _asked_width(options: dict[str, Any]) -> int | None:
    """The width a row reports before a file says otherwise: none where a target chooses it."""
    return None if _targeted(options) else options.get("width")


def _config_options(options: dict[str, Any]) -> dict[str, Any]:
    """The EncodeConfig fields among an asset's options (all but the targets)."""
    return {k: options[k] for k in ENCODE_OPTIONS if k in options and k not in TARGETS}


def encode_asset(input: str, options: dict[str, Any], threads: int | None) -> dict[str, Any]:
    """Load and encode one shape; never raises. Returns {status, data, field, seconds, tries, error, final}
    (`tries`: the encodes a target's search ran, None without a target):
    `final` marks a failure the same input bytes and options will always give (the input or an
    option rejected), which a rerun reports again instead of retrying; crashes, I/O errors, memory
    and a missing device are retried. It imports torch itself and writes nothing (the Ray task)."""
    start = time.perf_counter()
    final = False
    try:
        from .encoder import EncodeConfig, compress
        from .io import load_shape

        shape = load_shape(input, colors=options.get("color", "auto"))
        cfg = EncodeConfig(**_config_options(options), quiet=True, threads=threads)
        check_targets(*(options.get(k) for k in TARGETS))
        tries = None
        if options.get("target_bytes") is not None:
            from .targets import compress_to_bytes

            result, choice = compress_to_bytes(shape, cfg, options["target_bytes"])
            tries = len(choice.attempts) + (len(choice.color.attempts) if choice.color else 0)
        elif options.get("target_cd") is not None:
            from .targets import compress_to_distortion

            result, distortion = compress_to_distortion(shape, cfg, float(options["target_cd"]))
            tries = len(distortion.attempts)
        else:
            result = compress(shape, cfg)
        return {"status": "ok", "data": result.data, "field": result.field,
                "seconds": time.perf_counter() - start, "tries": tries, "error": None}
    except NfcError as e:
        message, final = e.message, not isinstance(e, DeviceError)
    except OSError as e:
        message = f"{e.filename}: {e.strerror}" if e.filename and e.strerror else str(e)
    except MemoryError:
        message = "out of memory"
    except Exception as e:  # noqa: BLE001 - a bug on one asset must not stop the library; the row says what
        message = f"internal error: {type(e).__name__}: {' '.join(str(e).split())}"
    if not message.startswith(input):
        message = f"{input}: {message}"
    return {"status": "error", "data": None, "field": None, "seconds": time.perf_counter() - start,
            "error": message, "final": final}


def encode_group(inputs: list[str], options: dict[str, Any], threads: int | None) -> list[dict[str, Any]]:
    """Several shapes with the same options trained as one batched model (`batch_train`); never
    raises. A shape that fails to load gets its error; if the group's training fails (one shape
    the encoder rejects), each remaining shape is encoded on its own, so only that one fails."""
    if len(inputs) == 1 or _targeted(options):
        return [encode_asset(path, options, threads) for path in inputs]
    start = time.perf_counter()
    results: list[dict[str, Any] | None] = [None] * len(inputs)
    try:
        from .batch_train import compress_many
        from .encoder import EncodeConfig
        from .io import load_shape

        shapes = []
        for i, path in enumerate(inputs):
            try:
                shapes.append((i, load_shape(path, colors=options.get("color", "auto"))))
            except NfcError as e:
                results[i] = {"status": "error", "data": None, "field": None, "seconds": 0.0,
                              "error": e.message if e.message.startswith(path) else f"{path}: {e.message}",
                              "final": True}
        cfg = EncodeConfig(**_config_options(options), quiet=True, threads=threads)
        encoded = compress_many([shape for _, shape in shapes], cfg)
        seconds = (time.perf_counter() - start) / max(1, len(shapes))  # the group's time, shared
        for (i, _), result in zip(shapes, encoded):
            results[i] = {"status": "ok", "data": result.data, "field": result.field, "seconds": seconds,
                          "error": None}
    except Exception:  # noqa: BLE001 - isolate: fall back to one task per shape
        return [r if r is not None and r["status"] == "error" else encode_asset(path, options, threads)
                for path, r in zip(inputs, results)]
    return [r for r in results if r is not None]


# --- Runners ---------------------------------------------------------------------------------------

Job = tuple[Asset, str]  # asset and its options hash
Done = Callable[[Job, dict[str, Any]], None]


def group_jobs(jobs: list[Job], size: int) -> list[list[Job]]:
    """Chunks of at most `size` jobs with identical options (in input order within each option set)."""
    by_options: dict[str, list[Job]] = {}
    for job in jobs:
        by_options.setdefault(json.dumps(job[0].options, sort_keys=True), []).append(job)
    return [same[i: i + size] for same in by_options.values() for i in range(0, len(same), size)]


def run_in_process(groups: list[list[Job]], threads: int | None, done: Done) -> None:
    for group in groups:
        results = encode_group([a.input for a, _ in group], group[0][0].options, threads)
        for job, result in zip(group, results):
            done(job, result)


@dataclass(frozen=True)
class RayOptions:
    address: str | None  # None: RAY_ADDRESS, else start a local cluster
    workers: int | None  # tasks in flight at once (None: as many as the cluster schedules)
    cpus_per_task: float
    gpus_per_task: float  # 0 on the CPU; a share of a GPU (e.g. 0.25) with --device cuda
    threads: int | None = None  # torch threads per task (None: cpus_per_task, at least 1)


def _ray_error_message(asset: Asset, e: BaseException) -> str:
    text = " ".join(str(e).split())
    first = text[:300] + ("..." if len(text) > 300 else "")
    return f"{asset.input}: worker failed ({type(e).__name__}): {first}"


def run_ray(groups: list[list[Job]], opts: RayOptions, done: Done) -> None:
    """Run the job groups as Ray tasks (one per group), at most `opts.workers` at a time. Joins `opts.address` (or
    RAY_ADDRESS) or starts a local cluster of workers × cpus_per_task CPUs, shut down at the end;
    an already initialised Ray (a caller's cluster) is used as it is and left running."""
    try:
        import ray
    except ImportError:
        raise InputError("encode-batch with --workers > 1 or --address needs Ray: "
                         "pip install 'nfencode[batch]' (or use --workers 1)") from None
    import nfencode

    owned = not ray.is_initialized()
    if owned:
        address = opts.address or os.environ.get("RAY_ADDRESS") or None
        # py_modules: every worker runs this driver's nfencode, whatever a node has installed.
        runtime_env = {"py_modules": [nfencode]}
        try:
            quiet = {"runtime_env": runtime_env, "log_to_driver": False, "logging_level": logging.WARNING}
            if address:
                ray.init(address=address, **quiet)
            else:
                workers = opts.workers or 1
                ray.init(num_cpus=max(1, round(workers * opts.cpus_per_task)), include_dashboard=False, **quiet)
        except Exception as e:  # noqa: BLE001 - ConnectionError, RuntimeError, ...: one line, not a traceback
            where = f"the Ray cluster at {address}" if address else "a local Ray cluster"
            raise NfcError(f"cannot start or join {where}: {' '.join(str(e).split())[:300]}") from None
    try:
        task = ray.remote(encode_group).options(num_cpus=opts.cpus_per_task, num_gpus=opts.gpus_per_task,
                                                max_retries=0)
        threads = opts.threads or max(1, int(opts.cpus_per_task))
        queue = list(reversed(groups))
        pending: dict[Any, list[Job]] = {}
        limit = opts.workers or len(groups)
        try:
            while queue or pending:
                while queue and len(pending) < limit:
                    group = queue.pop()
                    pending[task.remote([a.input for a, _ in group], group[0][0].options, threads)] = group
                ready, _ = ray.wait(list(pending), num_returns=1)
                for ref in ready:
                    group = pending.pop(ref)
                    try:
                        results = ray.get(ref)
                    except Exception as e:  # noqa: BLE001 - a crashed or killed worker: this task's assets only
                        results = [{"status": "error", "data": None, "field": None, "seconds": 0.0,
                                    "error": _ray_error_message(asset, e)} for asset, _ in group]
                    for job, result in zip(group, results):
                        done(job, result)
        except BaseException:
            for ref in pending:
                ray.cancel(ref, force=True)
            raise
    finally:
        if owned:
            ray.shutdown()


# --- The command -----------------------------------------------------------------------------------

@dataclass
class Summary:
    rows: list[dict[str, Any]]
    seconds: float

    def count(self, status: str) -> int:
        return sum(r["status"] == status for r in self.rows)

    @property
    def failed(self) -> bool:
        return self.count("error") > 0


def encode_batch(
    input_path: str | os.PathLike[str],
    outdir: str | os.PathLike[str],
    defaults: dict[str, Any],
    *,
    workers: int | None = 1,
    address: str | None = None,
    cpus_per_task: float = 1.0,
    gpus_per_task: float = 0.0,
    threads: int | None = None,
    group: int = 1,
    quiet: bool = False,
    report: Callable[[str], None] | None = None,
) -> Summary:
    """Encode every asset of INPUT into OUTDIR (module docstring). `workers=1` without an address
    runs in this process with `threads` torch threads; anything else runs on Ray. `group` > 1 trains
    up to that many assets with the same options per task as one batched model (`batch_train`; meant
    for GPUs). `report` receives one line per failed asset as it fails."""
    if group < 1:
        raise InputError(f"group must be >= 1, got {group}")
    start = time.perf_counter()
    _check_types(defaults, "options")
    plan = discover(input_path, defaults)
    out = Path(outdir)
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    previous = previous_rows(out)

    order = {a.name: i for i, a in enumerate(plan.assets)}
    final: dict[int, dict[str, Any]] = {}
    journal = open(out / RESULTS_NAME, "a", encoding="utf-8")  # noqa: SIM115 - closed in the finally below
    bar = tqdm(total=len(plan.assets) + len(plan.errors), desc="encode-batch", unit="asset",
               disable=True if quiet else None, dynamic_ncols=True)
    counts = {"ok": 0, "skipped": 0, "error": 0}

    def record(index: int, r: dict[str, Any]) -> None:
        final[index] = r
        journal.write(json.dumps(r) + "\n")
        journal.flush()
        counts[r["status"]] += 1
        bar.set_postfix(done=counts["ok"], skipped=counts["skipped"], failed=counts["error"], refresh=False)
        bar.update(1)
        if r["status"] == "error" and report is not None:
            bar.clear()
            report(r["error"])
            bar.refresh()

    def finished(job: Job, result: dict[str, Any]) -> None:
        asset, digest = job
        target = out / f"{asset.name}.nfc"
        r = row(asset.input, result["status"], seconds=result["seconds"], width=_asked_width(asset.options),
                options=asset.options, tries=result.get("tries"), error=result["error"])
        if result["status"] == "ok":
            try:
                write_atomic(target, result["data"])
                # The file's own width: a target_bytes search chose it.
                width = read_nfc(result["data"]).geometry.network.out_features[0]
                r.update(output=str(target), bytes=len(result["data"]), field=result["field"], width=width,
                         options_hash=digest)
            except OSError as e:
                r.update(status="error", error=f"{target}: cannot write ({e.strerror or e})")
        elif result.get("final"):
            r.update(options_hash=digest)  # the same bytes and options fail the same way: not retried
        record(order[asset.name], r)

    try:
        for k, r in enumerate(plan.errors):
            record(len(plan.assets) + k, r)
        jobs: list[Job] = []
        for asset in plan.assets:
            t0 = time.perf_counter()
            try:
                digest = options_hash(asset.options, file_digest(asset.input))
            except OSError as e:
                why = "no such file" if isinstance(e, FileNotFoundError) else f"cannot read ({e.strerror or e})"
                record(order[asset.name], row(asset.input, "error", width=_asked_width(asset.options),
                                              options=asset.options, error=f"{asset.input}: {why}",
                                              seconds=time.perf_counter() - t0))
                continue
            target = out / f"{asset.name}.nfc"
            before = previous.get(target.name)
            if (before is not None and before.get("options_hash") == digest and target.is_file()
                    and target.stat().st_size == before.get("bytes")):
                record(order[asset.name], row(asset.input, "skipped", output=str(target), bytes=before["bytes"],
                                              seconds=time.perf_counter() - t0, field=before.get("field"),
                                              width=before.get("width"), options=asset.options,
                                              tries=before.get("tries"), options_hash=digest))
            elif (failed := previous.get("error:" + asset.input)) is not None and failed["options_hash"] == digest:
                record(order[asset.name], row(asset.input, "error", seconds=time.perf_counter() - t0,
                                              width=_asked_width(asset.options), options=asset.options,
                                              error=failed.get("error"), options_hash=digest))
            else:
                jobs.append((asset, digest))
        if jobs:
            groups = group_jobs(jobs, group)
            if workers == 1 and address is None and not os.environ.get("RAY_ADDRESS"):
                run_in_process(groups, threads, finished)
            else:
                run_ray(groups, RayOptions(address, workers, cpus_per_task, gpus_per_task, threads), finished)
    finally:  # interrupted: the journal (previous rows + this run's so far) stays as it is
        bar.close()
        journal.close()
    rows = [final[i] for i in sorted(final)]
    write_atomic(out / RESULTS_NAME, "".join(json.dumps(r) + "\n" for r in rows).encode())
    return Summary(rows, time.perf_counter() - start)


__all__ = [
    "RESULTS_NAME",
    "ROW_KEYS",
    "Asset",
    "Plan",
    "RayOptions",
    "Summary",
    "available_cpus",
    "discover",
    "encode_asset",
    "encode_batch",
    "encode_group",
    "group_jobs",
    "options_hash",
    "previous_rows",
    "run_in_process",
    "run_ray",
    "write_atomic",
]
