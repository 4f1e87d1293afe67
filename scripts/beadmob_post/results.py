"""Reading beadmob result files (HDF5, schema in docs/output.md).

Only what the postprocessor needs is read, and anything else in the file (groups, datasets or
attributes added by later versions of beadmob, e.g. ``/mobility`` or ``/solver``) is ignored.
The Fortran program writes strings as fixed-length byte strings; they are decoded to ``str``
here so that callers never see ``bytes``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

#: Value of the root attribute ``format`` in every beadmob result file.
RESULT_FORMAT = "beadmob-result"
#: Newest ``format_version`` this reader understands.
SUPPORTED_FORMAT_VERSION = 1

#: Attributes of ``/shape`` that describe the shape but are not numeric shape parameters.
_SHAPE_DESCRIPTION_ATTRIBUTES = frozenset({"name", "source", "reference_length", "paper_length"})
#: Tolerance on the orthonormality of ``/geometry/body_axes``.
_AXES_TOLERANCE = 1e-6


class ResultFileError(Exception):
    """A file cannot be read as a beadmob result; the message names the file and the problem."""


@dataclass(frozen=True)
class Hydrodynamics:
    """``/hydrodynamics`` of a result file: the 6x6 friction and mobility (eta = 1, lengths in d).

    Rows and columns are ordered (x, y, z) of translation then rotation, in the input (model)
    coordinates, about the reference point named by ``attributes["reference_point"]`` (the
    centre of mass). Only ``friction`` is required; every other item is optional, and
    attributes unknown to this reader are kept in ``attributes`` untouched.
    """

    #: Maps (U, Omega) to (F, T).
    friction: np.ndarray
    #: Maps (F, T) to (U, Omega); None when the file holds only the friction.
    mobility: np.ndarray | None
    #: beadmob's own body frame for the mobility (rows = axes), coefficients, body mobility.
    body_axes: np.ndarray | None
    body_mobility: np.ndarray | None
    coefficients: np.ndarray | None
    #: All attributes of ``/hydrodynamics``, decoded (strings as str, arrays as numpy arrays).
    attributes: dict[str, Any] = field(default_factory=dict)
    #: The order-L friction alone, before the lubrication correction (``multipole_friction``;
    #: equal to ``friction`` when the run had no lubrication); None in older files.
    multipole_friction: np.ndarray | None = None
    #: beadmob's mu11 ... mu51 of ``multipole_friction`` (written when lubrication was on).
    multipole_coefficients: np.ndarray | None = None
    #: The point (input coordinates) about which the rotation-translation coupling is
    #: symmetric, and the mobility about it (input axes); None in older files.
    centre_of_mobility: np.ndarray | None = None
    mobility_at_centre_of_mobility: np.ndarray | None = None
    #: The companion friction of order L - 1 on the same beads (input coordinates, same reference
    #: point), from which the run's error bar is made; None when the run had no error estimate.
    companion_friction: np.ndarray | None = None
    #: The estimated absolute error of every entry of ``body_mobility`` (its frame: ``body_axes``);
    #: None when the file has no error estimate.
    body_mobility_error: np.ndarray | None = None

    @property
    def multipole_order(self) -> int | None:
        value = self.attributes.get("multipole_order")
        return int(value) if _is_real_number(value) else None

    @property
    def lubrication(self) -> bool | None:
        value = self.attributes.get("lubrication")
        return bool(value) if _is_real_number(value) else None

    @property
    def all_converged(self) -> bool | None:
        """False when beadmob flagged a non-converged solve, None when not recorded."""
        value = self.attributes.get("all_converged")
        return bool(value) if _is_real_number(value) else None


@dataclass(frozen=True)
class Flow:
    """``/flow`` of a result file (``&hydrodynamics flow = .true.``): the force- and torque-free
    body in a linear ambient flow u(r) = U + Omega x (r - R0) + E.(r - R0), R0 the centre of mass.

    E = sum_k e_k E_k over the five orthonormal symmetric traceless ``strain_modes``; the body
    moves with (U, Omega) + ``velocity_per_strain`` e and has the stresslet (Batchelor 1970)
    sum_l s_l E_l with s = ``stresslet_per_strain`` e (model coordinates, eta = 1, lengths in d).
    Arrays are read as h5py shows them, [row, column]; a (5, 6) velocity_per_strain or (3, 3, 5)
    strain_modes (the Fortran order read the other way) is turned to (6, 5) and (5, 3, 3).
    """

    strain_modes: np.ndarray
    velocity_per_strain: np.ndarray
    stresslet_per_strain: np.ndarray
    #: absolute error bars of the two responses; None when the file has none
    velocity_per_strain_error: np.ndarray | None = None
    stresslet_per_strain_error: np.ndarray | None = None
    attributes: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class BeadResult:
    """The contents of one beadmob result file that the postprocessor uses.

    Lengths are in bead diameters d. Arrays are read-only copies of the file's data.
    """

    path: Path
    #: Bead centres, shape (N, 3), in the input coordinates.
    positions: np.ndarray
    n_beads: int
    shape_name: str
    #: Numeric shape parameters, e.g. ``{"base_diameter": 21.0, "height": 50.0}``.
    shape_parameters: dict[str, float]
    centre_of_mass: np.ndarray
    #: Rows are the body x, y, z unit vectors in the input coordinates.
    body_axes: np.ndarray
    #: Size along the body axes (span of the centres plus one bead diameter).
    extent: np.ndarray
    #: Root attributes: format, format_version, program_version, git_hash, created, mpi_ranks, ...
    metadata: dict[str, Any] = field(default_factory=dict)
    #: Reference length L/d of the shape (``/shape`` attribute ``reference_length``), if any.
    reference_length: float | None = None
    #: Where the shape came from (``/shape`` attribute ``source``), if recorded.
    shape_source: str | None = None
    #: Input file path or "built-in default" (``/input`` attribute ``source``), if recorded.
    input_source: str | None = None
    #: Attributes of ``/units``, e.g. ``{"length": "d (bead diameter; ...)", "bead_diameter": 1.0}``.
    units: dict[str, Any] = field(default_factory=dict)
    #: 1 where the plane normal to body axis k is a mirror plane (``/geometry/mirror_planes``).
    mirror_planes: np.ndarray | None = None
    #: ``/hydrodynamics`` when the run computed it, else None.
    hydrodynamics: Hydrodynamics | None = None
    #: ``/flow`` when the run computed the response to a linear flow, else None.
    flow: Flow | None = None

    def body_coordinates(self) -> np.ndarray:
        """Bead centres in the body frame: origin at the centre of mass, axes ``body_axes``.

        Returns an (N, 3) array whose column k is the coordinate along body axis k.
        """
        return (self.positions - self.centre_of_mass) @ self.body_axes.T


def decode_value(value: Any) -> Any:
    """Turn an HDF5 attribute or dataset value into a plain Python value.

    Byte strings become ``str`` (undecodable bytes are replaced, never fatal), numpy scalars
    become Python numbers, and arrays are returned as numpy arrays (byte-string arrays decoded
    element by element into a list).
    """
    if isinstance(value, (bytes, np.bytes_)):
        return bytes(value).rstrip(b"\0").decode("utf-8", errors="replace")
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        if value.dtype.kind in ("S", "O", "U"):
            return [decode_value(item) for item in value.ravel()]
        return value
    return value


def load_result(path: str | Path) -> BeadResult:
    """Read the beadmob result file ``path``.

    Raises :class:`ResultFileError` when the file does not exist, is not an HDF5 file, was not
    written by beadmob, has a newer format version, or lacks (or has malformed) required data.
    """
    path = Path(path)
    if not path.exists():
        raise ResultFileError(f"{path}: no such file")
    if path.is_dir():
        raise ResultFileError(f"{path}: is a directory, not a result file")
    try:
        is_hdf5 = h5py.is_hdf5(path)
    except OSError as exc:
        raise ResultFileError(f"{path}: cannot read the file: {exc}") from exc
    if not is_hdf5:
        raise ResultFileError(f"{path} is not an HDF5 file")
    try:
        with h5py.File(path, "r") as handle:
            return _read_open_file(path, handle)
    except ResultFileError:
        raise
    except (OSError, KeyError, ValueError, TypeError) as exc:
        raise ResultFileError(f"{path}: cannot read the file: {exc}") from exc


def _read_open_file(path: Path, handle: h5py.File) -> BeadResult:
    """Check the format of an open file and read it into a :class:`BeadResult`."""
    metadata = {name: decode_value(value) for name, value in handle.attrs.items()}
    _check_format(path, metadata)

    geometry = _require_group(path, handle, "geometry")
    positions = _read_float_array(path, geometry, "positions")
    if positions.ndim != 2 or positions.shape[1] != 3:
        raise ResultFileError(
            f"{path}: /geometry/positions has shape {positions.shape}, expected (N, 3)"
        )
    n_beads = positions.shape[0]
    if "n_beads" in geometry.attrs:
        recorded = int(decode_value(geometry.attrs["n_beads"]))
        if recorded != n_beads:
            raise ResultFileError(
                f"{path}: /geometry attribute n_beads = {recorded} but /geometry/positions "
                f"holds {n_beads} beads"
            )
    centre_of_mass = _read_float_array(path, geometry, "centre_of_mass", expected_shape=(3,))
    body_axes = _read_float_array(path, geometry, "body_axes", expected_shape=(3, 3))
    extent = _read_float_array(path, geometry, "extent", expected_shape=(3,))
    if not np.allclose(body_axes @ body_axes.T, np.eye(3), atol=_AXES_TOLERANCE):
        raise ResultFileError(f"{path}: /geometry/body_axes is not an orthonormal frame")

    shape = _require_group(path, handle, "shape")
    shape_attributes = {name: decode_value(value) for name, value in shape.attrs.items()}
    shape_name = shape_attributes.get("name")
    if not isinstance(shape_name, str):
        raise ResultFileError(f"{path}: /shape has no string attribute 'name'")
    reference_length = shape_attributes.get(
        "reference_length", shape_attributes.get("paper_length")
    )
    shape_parameters = {
        name: float(value)
        for name, value in shape_attributes.items()
        if name not in _SHAPE_DESCRIPTION_ATTRIBUTES and _is_real_number(value)
    }

    mirror_planes = None
    if "mirror_planes" in geometry:
        mirror_planes = _read_only(
            _read_float_array(path, geometry, "mirror_planes", expected_shape=(3,))
        )
    hydrodynamics = None
    if "hydrodynamics" in handle:
        hydrodynamics = _read_hydrodynamics(path, _require_group(path, handle, "hydrodynamics"))

    flow = None
    if "flow" in handle:
        flow = _read_flow(path, _require_group(path, handle, "flow"))

    input_source = None
    if "input" in handle and "source" in handle["input"].attrs:
        input_source = decode_value(handle["input"].attrs["source"])
    units: dict[str, Any] = {}
    if "units" in handle:
        units = {name: decode_value(value) for name, value in handle["units"].attrs.items()}

    return BeadResult(
        path=path,
        positions=_read_only(positions),
        n_beads=n_beads,
        shape_name=shape_name,
        shape_parameters=shape_parameters,
        centre_of_mass=_read_only(centre_of_mass),
        body_axes=_read_only(body_axes),
        extent=_read_only(extent),
        metadata=metadata,
        reference_length=float(reference_length) if _is_real_number(reference_length) else None,
        shape_source=shape_attributes.get("source") if isinstance(
            shape_attributes.get("source"), str) else None,
        input_source=input_source if isinstance(input_source, str) else None,
        units=units,
        mirror_planes=mirror_planes,
        hydrodynamics=hydrodynamics,
        flow=flow,
    )


def _read_hydrodynamics(path: Path, group: h5py.Group) -> Hydrodynamics:
    """Read ``/hydrodynamics``: friction (required), the rest when present.

    The 6x6 matrices are read as stored: beadmob writes them so that C-order readers (h5py)
    see [row, column] (docs/output.md). ``bead_forces`` (N x 36) is not read.
    """
    # A run of some motions only (&hydrodynamics motions) leaves the friction entries between two
    # motions not computed NaN and has no mobility: those items then read as absent.
    partial = decode_value(group.attrs.get("motions", "all")) not in ("all", b"all")

    def optional(name: str, shape: tuple[int, ...]) -> np.ndarray | None:
        if name not in group or (partial and name != "multipole_friction"):
            return None
        return _read_only(_read_float_array(path, group, name, expected_shape=shape))

    friction = _read_only(_read_float_array(path, group, "friction", expected_shape=(6, 6), allow_nan=partial))
    multipole_friction = None
    if "multipole_friction" in group:
        multipole_friction = _read_only(_read_float_array(path, group, "multipole_friction", expected_shape=(6, 6),
                                                          allow_nan=partial))
    return Hydrodynamics(
        friction=friction,
        mobility=optional("mobility", (6, 6)),
        body_axes=optional("body_axes", (3, 3)),
        body_mobility=optional("body_mobility", (6, 6)),
        coefficients=optional("coefficients", (5,)),
        attributes={name: decode_value(value) for name, value in group.attrs.items()},
        multipole_friction=multipole_friction,
        multipole_coefficients=optional("multipole_coefficients", (5,)),
        centre_of_mobility=optional("centre_of_mobility", (3,)),
        mobility_at_centre_of_mobility=optional("mobility_at_centre_of_mobility", (6, 6)),
        companion_friction=optional("companion_friction", (6, 6)),
        body_mobility_error=optional("body_mobility_error", (6, 6)),
    )


#: Tolerance on the orthonormality of /flow/strain_modes.
_MODES_TOLERANCE = 1e-6


def _read_flow(path: Path, group: h5py.Group) -> Flow:
    """Read ``/flow``; the two error datasets are optional."""
    def read(name: str, shapes: tuple[tuple[int, ...], ...], required: bool = True) -> np.ndarray | None:
        if name not in group and not required:
            return None
        values = _read_float_array(path, group, name)
        if values.shape == shapes[0]:
            return _read_only(values)
        if len(shapes) > 1 and values.shape == shapes[1]:
            # The Fortran array read in the other index order.
            return _read_only(np.ascontiguousarray(np.moveaxis(values, -1, 0) if values.ndim == 3 else values.T))
        raise ResultFileError(f"{path}: dataset /flow/{name} has shape {values.shape}, expected {shapes[0]}")

    modes = read("strain_modes", ((5, 3, 3), (3, 3, 5)))
    gram = np.einsum("kij,lij->kl", modes, modes)
    if (not np.allclose(gram, np.eye(5), atol=_MODES_TOLERANCE)
            or not np.allclose(modes, np.swapaxes(modes, 1, 2), atol=_MODES_TOLERANCE)
            or not np.allclose(np.trace(modes, axis1=1, axis2=2), 0.0, atol=_MODES_TOLERANCE)):
        raise ResultFileError(f"{path}: /flow/strain_modes are not five orthonormal symmetric traceless tensors")
    return Flow(
        strain_modes=modes,
        velocity_per_strain=read("velocity_per_strain", ((6, 5), (5, 6))),
        stresslet_per_strain=read("stresslet_per_strain", ((5, 5),)),
        velocity_per_strain_error=read("velocity_per_strain_error", ((6, 5), (5, 6)), required=False),
        stresslet_per_strain_error=read("stresslet_per_strain_error", ((5, 5),), required=False),
        attributes={name: decode_value(value) for name, value in group.attrs.items()},
    )


def read_input_text(path: str | Path, effective: bool = False) -> str:
    """The input namelist echoed in the result file ``path``.

    With ``effective=True`` the configuration actually used (defaults included,
    ``/input/effective_namelist``) is returned instead of the input file as given.
    """
    path = Path(path)
    load_result(path)  # checks existence and format with clear messages
    name = "effective_namelist" if effective else "namelist"
    with h5py.File(path, "r") as handle:
        if "input" not in handle or name not in handle["input"]:
            raise ResultFileError(f"{path}: missing dataset /input/{name}")
        text = decode_value(handle["input"][name][()])
    if not isinstance(text, str):
        raise ResultFileError(f"{path}: /input/{name} is not a string")
    return text


def _check_format(path: Path, metadata: dict[str, Any]) -> None:
    """Reject files written by another program or by a newer, unknown format version."""
    if "format" not in metadata:
        raise ResultFileError(f"{path} is not a beadmob result file (no /format attribute)")
    if metadata["format"] != RESULT_FORMAT:
        raise ResultFileError(
            f"{path} is not a beadmob result file (format is {metadata['format']!r}, "
            f"expected {RESULT_FORMAT!r})"
        )
    version = metadata.get("format_version")
    if not isinstance(version, int):
        raise ResultFileError(f"{path}: missing or non-integer /format_version attribute")
    if version > SUPPORTED_FORMAT_VERSION:
        raise ResultFileError(
            f"{path} has format_version {version}; this postprocessor reads versions up to "
            f"{SUPPORTED_FORMAT_VERSION} (update beadmob_post)"
        )


def _require_group(path: Path, handle: h5py.File, name: str) -> h5py.Group:
    """The group ``/name`` or a :class:`ResultFileError` saying it is missing."""
    item = handle.get(name)
    if not isinstance(item, h5py.Group):
        raise ResultFileError(f"{path}: missing group /{name}")
    return item


def _read_float_array(
    path: Path,
    group: h5py.Group,
    name: str,
    expected_shape: tuple[int, ...] | None = None,
    allow_nan: bool = False,
) -> np.ndarray:
    """Read dataset ``name`` of ``group`` as finite float64 (NaN allowed with ``allow_nan``: the
    entries a partial run did not compute), checking its shape if given."""
    item = group.get(name)
    where = f"{group.name}/{name}"
    if not isinstance(item, h5py.Dataset):
        raise ResultFileError(f"{path}: missing dataset {where}")
    if item.dtype.kind not in ("f", "i", "u"):
        raise ResultFileError(f"{path}: dataset {where} is not numeric (type {item.dtype})")
    values = np.asarray(item[()], dtype=np.float64)
    if expected_shape is not None and values.shape != expected_shape:
        raise ResultFileError(
            f"{path}: dataset {where} has shape {values.shape}, expected {expected_shape}"
        )
    if not np.all(np.isfinite(values) | (allow_nan & np.isnan(values))):
        raise ResultFileError(f"{path}: dataset {where} holds non-finite values")
    return values


def _is_real_number(value: Any) -> bool:
    """True for int or float values (not bool, not strings)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _read_only(array: np.ndarray) -> np.ndarray:
    """Mark ``array`` read-only so that a frozen :class:`BeadResult` stays unchanged."""
    array.setflags(write=False)
    return array
