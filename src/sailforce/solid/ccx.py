"""CalculiX: writing an input deck for a :class:`~sailforce.solid.mesh.Mesh`, running ``ccx``, reading its ``.dat``.

CalculiX ships with Debian as ``calculix-ccx`` (``make test`` and ``make demo``
install it when missing).  Its habits this module handles:

- a number field holds at most 20 characters, so coordinates are written as ``%.12e``;
- set names come back upper case, so every name here is upper case already;
- ``*CLOAD, OP=NEW`` in each step, or the previous step's loads stay on;
- ``*EQUATION`` lines hold at most four terms;
- a failed run still exits 0: its ``*ERROR`` lines are what tell.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import SolverError
from .mesh import Mesh

#: The CalculiX binary: $SAIL_CCX, else the first of these on PATH.
CCX_NAMES = ("ccx", "ccx_2.20", "ccx_2.21", "ccx_2.22")
#: Seconds a single ccx run may take before it is stopped (a 3-D pose at a fine mesh takes a few minutes).
CCX_TIMEOUT_S = 1800
#: The message for a machine without CalculiX.
INSTALL_HINT = ("CalculiX is not installed: `make install-ccx` (Debian: apt-get install calculix-ccx) or set SAIL_CCX to "
                "the ccx binary")  # fmt: skip



def ccx_binary() -> str:
    """The path of CalculiX's ``ccx``, or :class:`SolverError` saying how to install it."""
    override = os.environ.get("SAIL_CCX")
    if override:
        if shutil.which(override) is None:
            raise SolverError(f"SAIL_CCX={override}: not an executable; {INSTALL_HINT}")
        return override
    for name in CCX_NAMES:
        path = shutil.which(name)
        if path:
            return path
    raise SolverError(INSTALL_HINT)


@dataclass(frozen=True)
class Step:
    """One load case: nodal forces ``loads`` (node id, dof 1-3, value [N]) and what to print."""

    loads: tuple[tuple[int, int, float], ...]
    forces: tuple[str, ...] = ()  #: node sets whose reaction forces RF to print
    displacements: tuple[str, ...] = ()  #: node sets whose displacements U to print
    stresses: tuple[str, ...] = ()  #: element sets whose stresses S to print


@dataclass(frozen=True)
class Deck:
    """Everything but the mesh: materials per part, boundary conditions, equations, steps."""

    sections: dict[str, tuple[float, float, float]]  #: part -> (E [Pa], nu, thickness [m])
    clamped: tuple[str, ...]  #: node sets held in every translation
    equations: tuple[tuple[tuple[int, int, float], ...], ...] = ()  #: each sum(coef u[node, dof]) = 0
    steps: tuple[Step, ...] = field(default_factory=tuple)
    extra_nodes: tuple[tuple[int, float, float], ...] = ()  #: (id, x, y) nodes no element holds: rigid bodies' references
    rigid: tuple[tuple[str, int, int], ...] = ()  #: (node set, reference node, rotation node) of each rigid body
    extra_sets: dict[str, tuple[int, ...]] = field(default_factory=dict)  #: node sets beyond the mesh's


def write_deck(path: Path, mesh: Mesh, deck: Deck) -> None:
    """The ``.inp`` file for ``mesh`` and ``deck``."""
    with open(path, "w", encoding="ascii") as out:
        out.write("*HEADING\nsailforce solid model\n*NODE, NSET=NALL\n")
        fmt = "%d, %.12e, %.12e\n"
        rows = np.column_stack([mesh.ids, mesh.nodes[:, :2]])
        out.writelines(fmt % tuple(row) for row in rows.tolist())
        out.writelines(fmt % (n, x, y) for n, x, y in deck.extra_nodes)
        number = 1
        for part, conn in mesh.elements.items():
            out.write(f"*ELEMENT, TYPE=CPS6, ELSET={part}\n")
            numbered = np.column_stack([np.arange(number, number + len(conn)), conn])
            out.writelines(_lines(row, 16) for row in numbered.tolist())
            number += len(conn)
        out.write("*ELSET, ELSET=EALL\n" + "".join(_lines(list(mesh.elements)[k:k + 8], 8) for k in range(0, len(mesh.elements), 8)))
        for name, ids in {**mesh.sets, **{k: np.asarray(v) for k, v in deck.extra_sets.items()}}.items():
            out.write(f"*NSET, NSET={name}\n")
            out.writelines(_lines(ids[k:k + 16].tolist(), 16) for k in range(0, len(ids), 16))
        for part, (E, nu, thickness) in deck.sections.items():
            out.write(f"*MATERIAL, NAME=M_{part}\n*ELASTIC\n{E:.12e}, {nu:.12e}\n")
            out.write(f"*SOLID SECTION, ELSET={part}, MATERIAL=M_{part}\n")
            out.write(f"{thickness:.12e}\n")
        if deck.clamped:
            out.write("*BOUNDARY\n" + "".join(f"{name}, 1, 2\n" for name in deck.clamped))
        for name, ref, rot in deck.rigid:
            out.write(f"*RIGID BODY, NSET={name}, REF NODE={ref}, ROT NODE={rot}\n")
        for terms in deck.equations:
            out.write(f"*EQUATION\n{len(terms)}\n")
            for k in range(0, len(terms), 4):
                out.write(", ".join(f"{n}, {d}, {c:.12e}" for n, d, c in terms[k:k + 4]) + "\n")
        for step in deck.steps:
            out.write("*STEP\n*STATIC\n*CLOAD, OP=NEW\n")
            out.writelines(f"{n}, {d}, {v:.12e}\n" for n, d, v in step.loads)
            for name in step.forces:
                out.write(f"*NODE PRINT, NSET={name}, TOTALS=YES\nRF\n")
            for name in step.displacements:
                out.write(f"*NODE PRINT, NSET={name}\nU\n")
            for name in step.stresses:
                out.write(f"*EL PRINT, ELSET={name}\nS\n")
            out.write("*END STEP\n")


def _lines(values: Sequence, per_line: int) -> str:
    return ", ".join(str(v) for v in values) + "\n"


@dataclass(frozen=True)
class Block:
    """One printed table of the ``.dat`` file: ``kind`` (``forces``, ``displacements``, ``stresses``), its set, its step."""

    kind: str
    name: str
    step: int
    ids: np.ndarray  #: node ids, or element ids for stresses
    values: np.ndarray  #: (rows, 3) for forces and displacements; (rows, 6) stresses, with ``points`` the integration point


_HEADER = re.compile(r"^\s*(displacements|forces|stresses) \(.*\) for set (\S+) and time\s+(\S+)")


def parse_dat(text: str) -> list[Block]:
    """Every table of a CalculiX ``.dat`` file, step numbers from the printed time (1 per step)."""
    blocks = []
    lines = text.splitlines()
    k = 0
    while k < len(lines):
        match = _HEADER.match(lines[k])
        k += 1
        if not match:
            continue
        rows = []
        while k < len(lines) and not lines[k].strip():
            k += 1
        while k < len(lines) and lines[k].strip() and not _HEADER.match(lines[k]):
            rows.append(lines[k].split())
            k += 1
        kind, name, time = match.group(1), match.group(2), float(match.group(3))
        table = np.array(rows, dtype=float) if rows else np.zeros((0, 4))
        ids = table[:, 0].astype(np.int64)
        values = table[:, 2:] if kind == "stresses" else table[:, 1:]
        blocks.append(Block(kind, name, int(round(time)), ids, values))
    return blocks


def run_ccx(mesh: Mesh, deck: Deck, *, workdir: str | Path | None = None, threads: int = 1) -> list[Block]:
    """Write, solve and read one deck; ``workdir`` keeps the files (a temporary directory otherwise)."""
    binary = ccx_binary()
    with tempfile.TemporaryDirectory(prefix="sail-ccx-") as scratch:
        where = Path(workdir) if workdir is not None else Path(scratch)
        where.mkdir(parents=True, exist_ok=True)
        write_deck(where / "arm.inp", mesh, deck)
        env = {**os.environ, "OMP_NUM_THREADS": str(threads), "CCX_NPROC_EQUATION_SOLVER": str(threads)}
        try:
            done = subprocess.run([binary, "-i", "arm"], cwd=where, env=env, capture_output=True, text=True,
                                  timeout=CCX_TIMEOUT_S, check=False)  # fmt: skip
        except subprocess.TimeoutExpired:
            raise SolverError(f"CalculiX did not finish within {CCX_TIMEOUT_S} s on {mesh.dofs} DOF") from None
        errors = _errors(done.stdout + done.stderr)
        if errors or done.returncode != 0:
            raise SolverError(f"CalculiX failed (exit {done.returncode}): {errors or done.stderr.strip()[-400:]}")
        try:
            return parse_dat((where / "arm.dat").read_text(encoding="ascii", errors="replace"))
        except FileNotFoundError:
            raise SolverError("CalculiX wrote no results (.dat)") from None


def _errors(log: str) -> str:
    """The first ``*ERROR`` of a ccx log and the line after it, in one line."""
    lines = log.splitlines()
    for k, line in enumerate(lines):
        if "*ERROR" in line:
            return " ".join(s.strip() for s in lines[k:k + 3] if s.strip())
    return ""


def select(blocks: Iterable[Block], kind: str, name: str, step: int) -> Block:
    """The table of ``kind`` for set ``name`` in ``step``."""
    for block in blocks:
        if block.kind == kind and block.name == name.upper() and block.step == step:
            return block
    raise SolverError(f"CalculiX printed no {kind} for {name} in step {step}")
