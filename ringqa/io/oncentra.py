"""Oncentra's applicator library, embedded in its RT Plans (private tag (300B,100D)).

Oncentra (Elekta/Nucletron) stores, in each item of the ApplicationSetupSequence, the applicator
model used for the plan as gzip-compressed UTF-16 XML under the private tag (300B,100D)
(private creator "NUCLETRON"). Structure of that XML (as found in OTP 4.3 exports)::

    <dataset>
      <build>
        <assembly>  CDATA: <configuration> ... <assembly part=ID label=R>
                                  <connection name=IU> <assembly part=ID2 label=IU/> ...
        <rules>     CDATA: which parts may be combined
        <part id=ID> CDATA: <part> <centerCurve tipLength=..> <point x y z/>... <marker1 x y z/>
                                   <lumen diameter=..> <connectors> <connector name=RO>
                                   <centerPoint/> <axisDirection/> <referenceDirection/> ...
                                   <skin> (surface mesh, not read)
        <sourcePath id=NAME> CDATA: <sourcePath stepsize=..> <sourcePositions>
                                   <connector name=RO ...> <sourcePosition x y z index=1../>
                                   <partConnections> <partConnection partid=ID connector=RO/>
      </build>
      <transforms> <transform jointAddress="@" matrix="16 numbers, row-major 4x4"/>
                   <transform jointAddress="@.IU" .../> </transforms>
    </dataset>

Mapping into the DICOM patient frame (verified on the shared 26 mm / 60 degree plan: the plan's ring
dwell positions coincide with the measured source path to < 1e-6 mm, the tandem dwells lie on the
tube centreline):

- a part at joint address ``@.A.B`` has library coordinates ``M(@) M(@.A) M(@.A.B) p``;
- library -> patient is ``(X, Y, Z) -> (X, -Z, Y)``;
- a measured source path is given in the frame of its connector (origin ``centerPoint``, axes
  ``axisDirection``, ``referenceDirection``); it is moved onto the part's connector of the same
  name (same construction) and then mapped like the part;
- centre curves run from the distal tip (first point) to the proximal end; ``marker1`` is the
  first marker (relative position 0 of the channel). ringqa returns centrelines PROXIMAL ->
  DISTAL and measured paths MOST DISTAL FIRST (sorted by ``index``).

The plan's channels name their part by joint address in the private tag (300B,xx13)
(``"@"``, ``"@.IU"``). Every private tag is read in the block reserved by the creator
``"NUCLETRON"`` (:func:`private_element`).
"""

from __future__ import annotations

import gzip
import re
import xml.etree.ElementTree as ET
import zlib
from dataclasses import dataclass, field

import numpy as np

#: Oncentra's private creator (group 0x300B) and the element offsets of its tags in that block
#: (read through pydicom's ``private_block``: the block is found by its creator string, never
#: by a fixed tag number, since another writer may reserve the block at another slot).
PRIVATE_GROUP = 0x300B
PRIVATE_CREATOR = "NUCLETRON"
#: offset of the library (setup item): gzip-compressed UTF-16 XML
LIBRARY_OFFSET = 0x0D
#: offset of the part's joint address ("@", "@.IU") in each channel item
JOINT_ADDRESS_OFFSET = 0x13
#: offset of the applicator model's name in the setup item
APPLICATOR_NAME_OFFSET = 0x10
#: offset of the applicator details (names the measured source path) in the setup item
APPLICATOR_DETAILS_OFFSET = 0x11

#: The tags as Oncentra writes them (block 0x10): for tests that build synthetic plans.
LIBRARY_TAG = (PRIVATE_GROUP, 0x1000 + LIBRARY_OFFSET)
JOINT_ADDRESS_TAG = (PRIVATE_GROUP, 0x1000 + JOINT_ADDRESS_OFFSET)
APPLICATOR_NAME_TAG = (PRIVATE_GROUP, 0x1000 + APPLICATOR_NAME_OFFSET)
APPLICATOR_DETAILS_TAG = (PRIVATE_GROUP, 0x1000 + APPLICATOR_DETAILS_OFFSET)


def private_element(item, offset: int):
    """Oncentra's private element at ``offset`` of ``item`` (a pydicom Dataset), or None.

    The block is looked up with ``item.private_block(0x300B, "NUCLETRON")``: the private
    creator string is checked, so a block of another vendor in the same group is never read as
    Oncentra's.
    """
    try:
        block = item.private_block(PRIVATE_GROUP, PRIVATE_CREATOR)
    except (KeyError, ValueError, AttributeError):
        return None
    try:
        return block[offset]
    except KeyError:
        return None


class LibraryFormatError(ValueError):
    """The library XML is not what this reader understands (caller turns it into a notice)."""


@dataclass(frozen=True)
class LibraryChannel:
    """One channel of an embedded applicator library, in DICOM patient coordinates (mm).

    Attributes
    ----------
    name : str
        The part's label in the library (``"R"`` ring, ``"IU"`` intra-uterine tube).
    role : str
        ``"ring"``, ``"tandem"`` or ``"other"`` (from the part's description).
    centreline_mm : numpy.ndarray
        (n, 3) channel centreline, PROXIMAL -> DISTAL, 1 mm spacing as in the library.
    lumen_diameter_mm : float or None
        Lumen diameter.
    measured_path_mm : numpy.ndarray or None
        (m, 3) measured source-centre positions, MOST DISTAL FIRST (relative positions 0, step,
        2 step, ...), when the library has a source path for this part.
    measured_path_name : str or None
        The source path's id (e.g. ``"VCC_RingCTMR_26x60_192-Ir-mxDR-v2 v1.1"``).
    measured_step_mm : float or None
        Spacing of the measured path's positions (relative positions).
    measured_path_origin : str
        The source path's provenance in words: label, version and creation date as stored in
        the library (``""`` without a path). Nothing in the library says how the path was
        obtained: it is the vendor's path for this applicator model, not a measurement of the
        user's applicator.
    marker_mm : numpy.ndarray or None
        (3,) the first marker (``marker1``) = where relative position 0 lies on the centreline.
    tip_length_mm : float or None
        The library's ``tipLength`` attribute (closed tip beyond the lumen), as stored.
    part_id : str
        Library part number (e.g. ``"110350-06"``).
    description : str
        Long description with its parameters filled in.
    joint_address : str
        ``"@"``, ``"@.IU"``, ...
    """

    name: str
    role: str
    centreline_mm: np.ndarray
    lumen_diameter_mm: float | None
    measured_path_mm: np.ndarray | None
    measured_path_name: str | None
    measured_step_mm: float | None
    marker_mm: np.ndarray | None
    tip_length_mm: float | None
    part_id: str
    description: str
    joint_address: str
    measured_path_origin: str = ""


@dataclass(frozen=True)
class _Part:
    part_id: str
    centre_curve: np.ndarray  # (n,3) library part frame, as stored (tip first)
    marker1: np.ndarray | None
    tip_length: float | None
    lumen_diameter: float | None
    connectors: dict  # name -> (centre (3,), axis (3,), ref (3,))
    description: str


@dataclass(frozen=True)
class _SourcePath:
    path_id: str
    positions: np.ndarray  # (m,3) in the path's connector frame, sorted by index
    step: float | None
    connector: tuple  # (name, centre, axis, ref)
    part_ids: tuple[str, ...]
    origin: str = ""  # label, version, creation date in words


@dataclass(frozen=True)
class OncentraLibrary:
    """The parsed library: parts, source paths, joint addresses and transforms (library frame)."""

    parts: dict = field(default_factory=dict)  # part id -> _Part
    source_paths: dict = field(default_factory=dict)  # id -> _SourcePath
    addresses: dict = field(default_factory=dict)  # joint address -> (part id, label)
    transforms: dict = field(default_factory=dict)  # joint address -> (4,4)
    label: str = ""


def decode_library(raw: bytes) -> str:
    """Gunzip and decode (UTF-16, else UTF-8) the bytes of tag (300B,100D)."""
    try:
        data = gzip.decompress(bytes(raw))
    except (OSError, EOFError, zlib.error) as exc:
        raise LibraryFormatError(f"not gzip data ({exc})") from None
    for enc in ("utf-16", "utf-8"):
        try:
            text = data.decode(enc)
        except UnicodeDecodeError:
            continue
        if text.lstrip().startswith("<"):
            return text
    raise LibraryFormatError("decompressed data is not UTF-16/UTF-8 XML")


def _xml(text: str) -> ET.Element:
    text = re.sub(r"^\s*<\?xml[^>]*\?>", "", text.strip())
    try:
        return ET.fromstring(text)
    except ET.ParseError as exc:
        raise LibraryFormatError(f"XML parse error ({exc})") from None


def _inner(el: ET.Element) -> ET.Element:
    """An element whose text is a CDATA XML document (or which has the document as a child)."""
    if el.text and el.text.strip():
        return _xml(el.text)
    children = list(el)
    if len(children) == 1:
        return children[0]
    raise LibraryFormatError(f"<{el.tag}> has no embedded document")


def _vec(el: ET.Element | None, what: str) -> np.ndarray:
    if el is None:
        raise LibraryFormatError(f"missing <{what}>")
    try:
        v = np.array([float(el.get(a)) for a in "xyz"])
    except (TypeError, ValueError):
        raise LibraryFormatError(f"<{what}> lacks numeric x, y, z") from None
    if not np.all(np.isfinite(v)):
        raise LibraryFormatError(f"<{what}> is not finite")
    return v


def _connector(el: ET.Element) -> tuple:
    return (
        el.get("name", ""),
        _vec(el.find("centerPoint"), "centerPoint"),
        _vec(el.find("axisDirection"), "axisDirection"),
        _vec(el.find("referenceDirection"), "referenceDirection"),
    )


def _float_attr(el: ET.Element | None, name: str) -> float | None:
    if el is None or el.get(name) is None:
        return None
    try:
        return float(el.get(name))
    except ValueError:
        return None


def parse_library(text: str) -> OncentraLibrary:
    """Parse the decoded library XML (see the module docstring for the structure)."""
    root = _xml(text)
    parts: dict = {}
    for el in root.iter("part"):
        doc = _inner(el)
        cc = doc.find("centerCurve")
        if cc is None:
            continue
        pts = np.array([_vec(p, "point") for p in cc.findall("point")])
        if len(pts) < 4:
            raise LibraryFormatError(f"part {el.get('id')}: centre curve has {len(pts)} points")
        m1 = cc.find("marker1")
        desc_el = doc.find("information/description")
        desc = ""
        if desc_el is not None:
            desc = desc_el.findtext("longDescription", "") or ""
            params = [p.text or "" for p in desc_el.findall("parameter")]
            try:
                desc = desc.format(*params)
            except (IndexError, KeyError, ValueError):
                pass
        parts[el.get("id")] = _Part(
            part_id=el.get("id"),
            centre_curve=pts,
            marker1=None if m1 is None else _vec(m1, "marker1"),
            tip_length=_float_attr(cc, "tipLength"),
            lumen_diameter=_float_attr(doc.find("lumen"), "diameter"),
            connectors={
                c.get("name"): _connector(c) for c in doc.iter("connector") if c.get("name")
            },
            description=desc,
        )
    paths: dict = {}
    for el in root.iter("sourcePath"):
        doc = _inner(el)
        sp = doc.find("sourcePositions")
        if sp is None:
            continue
        items = sorted(sp.findall("sourcePosition"), key=lambda e: int(e.get("index", "0")))
        con = sp.find("connector")
        paths[el.get("id")] = _SourcePath(
            path_id=el.get("id"),
            positions=np.array([_vec(p, "sourcePosition") for p in items]),
            step=_float_attr(doc, "stepsize"),
            connector=_connector(con) if con is not None else ("", np.zeros(3), None, None),
            part_ids=tuple(pc.get("partid") for pc in doc.iter("partConnection")),
            origin=_path_origin(el.get("id"), doc),
        )
    addresses: dict = {}
    label = ""
    build = root.find("build")
    conf_el = build.find("assembly") if build is not None else None
    if conf_el is not None:
        conf = _inner(conf_el)
        label = conf.get("label", "")
        top = conf.find("assembly")
        if top is not None:
            _walk(top, "@", addresses)
    transforms = {}
    for t in root.iter("transform"):
        try:
            m = np.array(t.get("matrix", "").split(), dtype=float).reshape(4, 4)
        except ValueError:
            raise LibraryFormatError(
                f"transform {t.get('jointAddress')} is not 16 numbers"
            ) from None
        transforms[t.get("jointAddress")] = m
    if not parts:
        raise LibraryFormatError("no applicator parts with a centre curve")
    return OncentraLibrary(parts, paths, addresses, transforms, label)


def _path_origin(path_id: str | None, doc: ET.Element) -> str:
    """A source path's provenance in words: its label, version and creation date."""
    label = doc.get("label") or path_id or "unnamed"
    parts = [f"Oncentra applicator library source path {label!r}"]
    if doc.get("version"):
        parts.append(f"version {doc.get('version')}")
    date = (doc.get("creationDate") or "")[:10]
    if date:
        parts.append(f"created {date}")
    return ", ".join(parts)


def _walk(assembly: ET.Element, address: str, out: dict) -> None:
    out[address] = (assembly.get("part"), assembly.get("label", ""))
    for con in assembly.findall("connection"):
        child = con.find("assembly")
        if child is not None:
            _walk(child, f"{address}.{con.get('name')}", out)


def _frame(axis: np.ndarray, ref: np.ndarray) -> np.ndarray:
    a = axis / np.linalg.norm(axis)
    r = ref - a * (a @ ref)
    r = r / np.linalg.norm(r)
    return np.column_stack([a, r, np.cross(a, r)])


def _library_to_patient(points: np.ndarray) -> np.ndarray:
    """Library frame -> DICOM patient frame: (X, Y, Z) -> (X, -Z, Y)."""
    return np.column_stack([points[:, 0], -points[:, 2], points[:, 1]])


def address_transform(lib: OncentraLibrary, address: str) -> np.ndarray:
    """The 4x4 part -> library transform of a joint address (product along the chain)."""
    parts = address.split(".")
    m = np.eye(4)
    for k in range(1, len(parts) + 1):
        a = ".".join(parts[:k])
        if a not in lib.transforms:
            raise LibraryFormatError(f"no transform for joint address {a!r}")
        t = lib.transforms[a]
        if not np.all(np.isfinite(t)):
            bad = [f"{v:g}" for v in t.ravel() if not np.isfinite(v)]
            raise LibraryFormatError(
                f"the transform for joint address {a!r} has non-finite entries "
                f"({', '.join(sorted(set(bad)))}): every point of the part would be undefined"
            )
        m = m @ t
    return m


def _apply(m: np.ndarray, pts: np.ndarray) -> np.ndarray:
    return pts @ m[:3, :3].T + m[:3, 3]


def _role(description: str, label: str) -> str:
    d = f"{description} {label}".lower()
    if "ring" in d:
        return "ring"
    if "intrauterine" in d or "tandem" in d or label.upper() == "IU":
        return "tandem"
    return "other"


def library_channel(
    lib: OncentraLibrary, address: str, preferred_path: str | None = None
) -> LibraryChannel:
    """The library channel at a joint address, mapped into patient coordinates.

    Parameters
    ----------
    lib : OncentraLibrary
        Parsed library.
    address : str
        Joint address from the plan's channel (tag (300B,1013)), e.g. ``"@"``.
    preferred_path : str, optional
        Source-path id to prefer when several paths fit the part (the plan names the one used).
    """
    if address not in lib.addresses:
        raise LibraryFormatError(f"joint address {address!r} is not in the configuration")
    part_id, label = lib.addresses[address]
    if part_id not in lib.parts:
        raise LibraryFormatError(f"part {part_id} (joint {address}) has no centre curve")
    part = lib.parts[part_id]
    m = address_transform(lib, address)

    def to_patient(pts: np.ndarray) -> np.ndarray:
        return _library_to_patient(_apply(m, np.atleast_2d(pts)))

    centreline = to_patient(part.centre_curve)[::-1].copy()  # library: tip first
    marker = None if part.marker1 is None else to_patient(part.marker1)[0]
    measured = name = step = None
    origin = ""
    candidates = [p for p in lib.source_paths.values() if part_id in p.part_ids]
    if preferred_path is not None:
        candidates.sort(key=lambda p: p.path_id != preferred_path)
    for sp in candidates:
        cname, c_path, a_path, r_path = sp.connector
        if cname not in part.connectors or a_path is None:
            continue
        _, c_part, a_part, r_part = part.connectors[cname]
        rot = _frame(a_part, r_part) @ _frame(a_path, r_path).T
        in_part = (sp.positions - c_path) @ rot.T + c_part
        measured, name, step = to_patient(in_part), sp.path_id, sp.step
        origin = sp.origin
        if step is not None and not (np.isfinite(step) and step > 0):
            raise LibraryFormatError(
                f"source path {name!r}: stepsize {step:g} is not a positive finite spacing (mm)"
            )
        break
    for what, value in (("lumen diameter", part.lumen_diameter), ("tipLength", part.tip_length)):
        if value is not None and not np.isfinite(value):
            raise LibraryFormatError(f"part {part_id}: {what} is {value:g}, not a finite number")
    for what, pts in (("centre curve", centreline), ("marker1", marker), ("source path", measured)):
        if pts is not None and not np.all(np.isfinite(pts)):
            raise LibraryFormatError(f"part {part_id}: {what} has non-finite coordinates")
    return LibraryChannel(
        name=label,
        role=_role(part.description, label),
        centreline_mm=np.ascontiguousarray(centreline),
        lumen_diameter_mm=part.lumen_diameter,
        measured_path_mm=None if measured is None else np.ascontiguousarray(measured),
        measured_path_name=name,
        measured_step_mm=step,
        marker_mm=marker,
        tip_length_mm=part.tip_length,
        part_id=part_id,
        description=part.description,
        joint_address=address,
        measured_path_origin=origin,
    )
