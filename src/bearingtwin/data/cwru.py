"""Case Western Reserve University bearing data: .mat records, names, and a checked sampling rate.

A CWRU file holds ``X<nnn>_DE_time`` / ``_FE_time`` / ``_BA_time`` accelerations (g) and
``X<nnn>RPM``, the measured speed, but not its sampling rate; the rate (12 kHz for the
drive-end records used here) is a convention of the data set, and the literature
disagrees about some records (97 may be 48 kHz). So the rate is *declared* per record
and then *checked*: a shaft turning at ``rpm`` puts a series of lines at multiples of
``rpm / 60`` into the spectrum, and under a wrong rate that series appears scaled by
``declared / true``. :func:`bearingtwin.signal.sampling_rate.check_sampling_rate` looks for it.
"""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from bearingtwin.data.formats import RawRecord, read_raw, recording_from_raw, same_speed
from bearingtwin.data.recording import Recording
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.signal.sampling_rate import check_channels, decisive_channel, describe_mismatch, rate_witnesses

log = logging.getLogger(__name__)

CHANNELS = ("DE", "FE", "BA")
DECLARED_FS_HZ = 12000.0
"""The rate the Data Center states for its 12k drive-end files; overridable per record in config."""

STATES = {"normal": "normal", "IR": "inner", "B": "ball", "OR": "outer"}

NOMINAL_RPM_BY_LOAD_HP = {0: 1797.0, 1: 1772.0, 2: 1750.0, 3: 1730.0}
"""Motor speed by motor load in the Data Center's tables: the speed of a file that records none."""

BEARING_BY_END = {"drive": "cwru_6205", "fan": "cwru_6203"}
"""The rig's two bearings: the drive end's SKF 6205 and the fan end's SKF 6203."""
CHANNEL_BY_END = {"drive": "DE", "fan": "FE"}
"""The accelerometer on each bearing's housing."""

_VARIABLE = re.compile(r"^X(\d+)_(DE|FE|BA)_time$")
_NAME = re.compile(
    r"^(?:(?P<rate>\d+k)_(?P<end>Drive|Fan)_End_(?P<state>IR|B|OR)(?P<size>\d{3})(?:@(?P<position>\d+))?"
    r"|(?P<normal>normal))_(?P<load>\d)_(?P<record>\d+)$"
)
_CONDITION = re.compile(r"^(?:(?P<state>IR|B|OR)(?P<size>\d{3})(?:@(?P<position>\d+))?|(?P<normal>normal))_(?P<load>\d)$",
                        re.IGNORECASE)
"""The Data Center's own label of a record (``IR014_1``, ``OR021@12_0``, ``Normal_0``), which mirrors name files by."""

DATA_CENTER_12K_DRIVE_END = {
    97: "Normal_0", 98: "Normal_1", 99: "Normal_2", 100: "Normal_3",
    105: "IR007_0", 106: "IR007_1", 107: "IR007_2", 108: "IR007_3",
    169: "IR014_0", 170: "IR014_1", 171: "IR014_2", 172: "IR014_3",
    209: "IR021_0", 210: "IR021_1", 211: "IR021_2", 212: "IR021_3",
    3001: "IR028_0", 3002: "IR028_1", 3003: "IR028_2", 3004: "IR028_3",
    118: "B007_0", 119: "B007_1", 120: "B007_2", 121: "B007_3",
    185: "B014_0", 186: "B014_1", 187: "B014_2", 188: "B014_3",
    222: "B021_0", 223: "B021_1", 224: "B021_2", 225: "B021_3",
    3005: "B028_0", 3006: "B028_1", 3007: "B028_2", 3008: "B028_3",
    130: "OR007@6_0", 131: "OR007@6_1", 132: "OR007@6_2", 133: "OR007@6_3",
    144: "OR007@3_0", 145: "OR007@3_1", 146: "OR007@3_2", 147: "OR007@3_3",
    156: "OR007@12_0", 158: "OR007@12_1", 159: "OR007@12_2", 160: "OR007@12_3",
    197: "OR014@6_0", 198: "OR014@6_1", 199: "OR014@6_2", 200: "OR014@6_3",
    234: "OR021@6_0", 235: "OR021@6_1", 236: "OR021@6_2", 237: "OR021@6_3",
    246: "OR021@3_0", 247: "OR021@3_1", 248: "OR021@3_2", 249: "OR021@3_3",
    258: "OR021@12_0", 259: "OR021@12_1", 260: "OR021@12_2", 261: "OR021@12_3",
}
"""The Data Center's catalogue of its 12 kHz drive-end fault records and the normal baseline: record number ->
label. Its download files are named by the number alone (``170.mat``); the catalogue says what each holds (there
is no record 157)."""
DATA_CENTER_48K_DRIVE_END = {
    109: "IR007_0", 110: "IR007_1", 111: "IR007_2", 112: "IR007_3",
    174: "IR014_0", 175: "IR014_1", 176: "IR014_2", 177: "IR014_3",
    213: "IR021_0", 214: "IR021_1", 215: "IR021_2", 217: "IR021_3",
    122: "B007_0", 123: "B007_1", 124: "B007_2", 125: "B007_3",
    189: "B014_0", 190: "B014_1", 191: "B014_2", 192: "B014_3",
    226: "B021_0", 227: "B021_1", 228: "B021_2", 229: "B021_3",
    135: "OR007@6_0", 136: "OR007@6_1", 137: "OR007@6_2", 138: "OR007@6_3",
    148: "OR007@3_0", 149: "OR007@3_1", 150: "OR007@3_2", 151: "OR007@3_3",
    161: "OR007@12_0", 162: "OR007@12_1", 163: "OR007@12_2", 164: "OR007@12_3",
    201: "OR014@6_0", 202: "OR014@6_1", 203: "OR014@6_2", 204: "OR014@6_3",
    238: "OR021@6_0", 239: "OR021@6_1", 240: "OR021@6_2", 241: "OR021@6_3",
    250: "OR021@3_0", 251: "OR021@3_1", 252: "OR021@3_2", 253: "OR021@3_3",
    262: "OR021@12_0", 263: "OR021@12_1", 264: "OR021@12_2", 265: "OR021@12_3",
}
"""The Data Center's catalogue of its 48 kHz drive-end fault records (no record 216)."""
DATA_CENTER_12K_FAN_END = {
    278: "IR007_0", 279: "IR007_1", 280: "IR007_2", 281: "IR007_3",
    274: "IR014_0", 275: "IR014_1", 276: "IR014_2", 277: "IR014_3",
    270: "IR021_0", 271: "IR021_1", 272: "IR021_2", 273: "IR021_3",
    282: "B007_0", 283: "B007_1", 284: "B007_2", 285: "B007_3",
    286: "B014_0", 287: "B014_1", 288: "B014_2", 289: "B014_3",
    290: "B021_0", 291: "B021_1", 292: "B021_2", 293: "B021_3",
    294: "OR007@6_0", 295: "OR007@6_1", 296: "OR007@6_2", 297: "OR007@6_3",
    298: "OR007@3_0", 299: "OR007@3_1", 300: "OR007@3_2", 301: "OR007@3_3",
    302: "OR007@12_0", 305: "OR007@12_1", 306: "OR007@12_2", 307: "OR007@12_3",
    313: "OR014@6_0", 310: "OR014@3_0", 309: "OR014@3_1", 311: "OR014@3_2", 312: "OR014@3_3",
    315: "OR021@6_0", 316: "OR021@3_1", 317: "OR021@3_2", 318: "OR021@3_3",
}
"""The Data Center's catalogue of its 12 kHz fan-end fault records: the fault in the fan-end bearing (SKF 6203)."""
DATA_CENTER_CATALOGUE = {
    **{number: (label, DECLARED_FS_HZ, "drive") for number, label in DATA_CENTER_12K_DRIVE_END.items()},
    **{number: (label, 48000.0, "drive") for number, label in DATA_CENTER_48K_DRIVE_END.items()},
    **{number: (label, DECLARED_FS_HZ, "fan") for number, label in DATA_CENTER_12K_FAN_END.items()},
}
"""Every record number the Data Center names its download files by -> (label, sampling rate in Hz, faulty bearing's
end). The normal baseline's rate is in doubt (some state 48 kHz for record 97): it is declared and checked."""


@dataclass(frozen=True)
class CwruName:
    """What a CWRU file name says (``12k_Drive_End_OR007@6_0_130.mat``, ``normal_0_97.mat``)."""

    fault: str
    load_hp: int
    record: int | None  # None for a label, which names no record (mirrors file 12 and 48 kHz records under one label),
    # until the variables it holds name a catalogued one (read_cwru_raw)
    fault_size_in: float | None = None  # defect diameter in inches (0.007 for "007")
    position: str | None = None  # outer-race defect position in o'clock ("6"), None elsewhere
    rate_hz: float | None = None  # sampling rate the name states ("48k_..." -> 48000), None when it states none
    end: str | None = None  # the faulty bearing: "drive" (SKF 6205) or "fan" (SKF 6203); None when the name does not say
    form: str = "long"  # "long" (12k_Drive_End_IR007_0_105), "number" (105, the catalogue's) or "label" (IR007_0)

    @property
    def bearing(self) -> str | None:
        """The bearing config (``conf/bearing/<name>.yaml``) of the faulty bearing, when the name says which."""
        return BEARING_BY_END.get(self.end)


def parse_cwru_name(path: str | Path) -> CwruName | None:
    """The state, motor load and record number in a CWRU file name (None for another form).

    Three forms are read: the long one (``12k_Drive_End_IR014_1_170.mat``), the Data Center's record number
    (``170.mat``, as its catalogue lists it: :data:`DATA_CENTER_CATALOGUE`, which gives the rate and the bearing's
    end too) and its label of the record's
    condition (``IR014_1.mat``, ``Normal_0.mat``), which states neither the record, the rate nor the bearing's end.
    """
    stem = Path(path).stem
    if stem.isdigit() and int(stem) in DATA_CENTER_CATALOGUE:
        text, rate_hz, end = DATA_CENTER_CATALOGUE[int(stem)]
        label = _parse_condition(text)
        faulty = label.fault != "normal"
        return replace(label, record=int(stem), form="number", rate_hz=rate_hz if faulty else None,
                       end=end if faulty else None)
    label = _parse_condition(stem)
    if label is not None:
        return label
    match = _NAME.match(stem)
    if match is None:
        return None
    if match["normal"]:
        return CwruName(fault="normal", load_hp=int(match["load"]), record=int(match["record"]))
    return CwruName(
        fault=STATES[match["state"]],
        load_hp=int(match["load"]),
        record=int(match["record"]),
        fault_size_in=int(match["size"]) / 1000.0,
        position=match["position"],
        rate_hz=1000.0 * int(match["rate"][:-1]),
        end=match["end"].lower(),
    )


def _parse_condition(stem: str) -> CwruName | None:
    """A Data Center label (``OR021@12_0``) as a name: state, size, position and load; no record, rate or end."""
    match = _CONDITION.match(stem)
    if match is None:
        return None
    if match["normal"]:
        return CwruName(fault="normal", load_hp=int(match["load"]), record=None, form="label")
    return CwruName(fault=STATES[match["state"].upper()], load_hp=int(match["load"]), record=None,
                    fault_size_in=int(match["size"]) / 1000.0, position=match["position"], form="label")


def is_cwru_mat(variables: dict) -> bool:
    """Whether a loaded .mat file has the CWRU layout (``X<nnn>_<channel>_time`` variables)."""
    return any(_VARIABLE.match(name) for name in variables)


def read_cwru_raw(path: str | Path, variables: dict) -> RawRecord:
    """The DE / FE / BA channels and measured speed of a loaded CWRU .mat file.

    The Data Center's files are not all packaged alike, and what a reader does about each is said in
    the record's ``meta["notes"]``: the 0.028 in records keep their samples under another number
    (``3001.mat`` holds ``X056_DE_time``) and state no speed, so the speed is the Data Center's
    nominal one for the motor load the name gives; some files hold a second record's variables
    (``99.mat`` holds ``X098_*`` too), and the one the name gives is read.
    """
    path = Path(path)
    by_record: dict[int, dict[str, np.ndarray]] = {}
    for variable, value in variables.items():
        match = _VARIABLE.match(variable)
        if match:
            by_record.setdefault(int(match[1]), {})[match[2]] = np.asarray(value, dtype=np.float64).reshape(-1)
    name = parse_cwru_name(path)
    named = named_record(path)
    notes = []
    if len(by_record) == 1:
        record = next(iter(by_record))
        if name is not None and name.form == "label":
            _refuse_another_condition(path, name, record)
            name, known = _label_read_by_its_record(name, record)
            notes += known
        notes += _catalogue_disagrees(name)
        if named is not None and named != record:
            _refuse_another_catalogued_record(path, named, record)
            notes.append(f"its variables are X{record:03d}_* while the name says record {named}; read as the name's "
                         "record (the Data Center packages some files so: 3001.mat holds X056_*)")
    elif named in by_record:
        record = named
        others = ", ".join(f"X{other:03d}_*" for other in sorted(by_record) if other != named)
        notes.append(f"{others} in the same file left out: the name gives record {named}")
    else:
        which = "names none of them" if named is None else f"names record {named}, which is not among them"
        raise BearingTwinError(f"{path}: holds the variables of records {sorted(by_record)} and its name {which} "
                               "(name it <record>.mat)")
    rpm_names = [n for n in variables if re.fullmatch(rf"X0*{record}RPM", n)]
    rpm = float(np.asarray(variables[rpm_names[0]]).reshape(-1)[0]) if rpm_names else None
    nominal_rpm = None if name is None or rpm is not None else NOMINAL_RPM_BY_LOAD_HP.get(name.load_hp)
    notes += _name_notes(path, name, rpm)
    meta = {"record": record if named is None else named, "notes": notes}
    if name is not None:
        meta.update(load_hp=name.load_hp, fault_size_in=name.fault_size_in, position=name.position)
    if name is not None and name.rate_hz is not None:
        meta["named_rate"] = {"hz": name.rate_hz, "by": (f"the Data Center's catalogue lists record {name.record} at"
                                                         if name.form in ("number", "label") else "its name states")}
    if name is not None and name.end is not None:  # the faulty bearing
        meta["bearing"] = name.bearing
    elif name is not None and name.fault == "normal":  # no faulty bearing: the one under the accelerometer read
        meta["bearing_by_channel"] = {CHANNEL_BY_END[end]: bearing for end, bearing in BEARING_BY_END.items()}
    channels = by_record[record]
    own = CHANNEL_BY_END[name.end] if name is not None and name.end else None  # the faulty bearing's accelerometer
    if name is not None and name.end == "fan" and own in channels:  # the 6205 is the bearing the data set is known by
        notes.append("the fault is in the fan-end bearing (SKF 6203, conf/bearing/cwru_6203.yaml), whose own "
                     "accelerometer, FE, is read unless a channel is named")
    if own is not None and own not in channels and len(channels) == 1:  # the one the file holds is read, said so
        notes.append(f"it holds no {own} channel, the accelerometer on the faulty {name.end}-end bearing: its one "
                     f"channel, {next(iter(channels))}, is read")
    return RawRecord(
        str(path),
        "cwru-mat",
        {channel: channels[channel] for channel in CHANNELS if channel in channels},
        fs=DECLARED_FS_HZ if name is None or name.rate_hz is None else name.rate_hz,
        fs_origin="declared",  # a convention of the data set (the name's 12k / 48k at best), checked, not measured
        rpm=rpm,
        nominal_rpm=nominal_rpm,
        nominal_rpm_note=f"speed {nominal_rpm:g} rpm: the Data Center's nominal speed at {name.load_hp} hp "
                         f"(no X{record:03d}RPM variable)" if nominal_rpm else "",
        fault=None if name is None else name.fault,
        unit="g",
        meta=meta,
        # The faulty bearing's own accelerometer; the drive end's for the healthy records, the one the data set is known by.
        default_channel=CHANNEL_BY_END[name.end] if name is not None and name.end else "DE",
    )


def _refuse_another_catalogued_record(path: Path, named: int, held: int) -> None:
    """Refuse a file whose variables are those of a record the catalogue lists as another condition, rate or bearing
    end than the record its name gives (``105.mat`` holding ``X118_*``, a ball record): a copy under the wrong
    name, which read as its name would be scored against the wrong truth. Numbers outside the catalogue pass (the
    Data Center's own 0.028 in files hold ``X056_*`` and the like)."""
    if named in DATA_CENTER_CATALOGUE and held in DATA_CENTER_CATALOGUE and (
            DATA_CENTER_CATALOGUE[named] != DATA_CENTER_CATALOGUE[held]):
        raise BearingTwinError(f"{path}: holds record {held}'s variables (X{held:03d}_*: {_catalogue_words(held)} in the "
                               f"Data Center's catalogue), while its name gives record {named} ({_catalogue_words(named)}): "
                               "name the file by the record it holds")


def _catalogue_words(number: int) -> str:
    """What the Data Center's catalogue lists record ``number`` as: "OR007@6_1 at 12 kHz, drive end"."""
    label, rate_hz, end = DATA_CENTER_CATALOGUE[number]
    return f"{label} at {rate_hz / 1000:g} kHz, {end} end"


def _refuse_another_condition(path: Path, label: CwruName, held: int) -> None:
    """Refuse a file named by a Data Center label (``IR007_1.mat``) whose variables are those of a record the
    catalogue lists under another condition (``X131_*``: OR007@6_1): read as its name, it would be scored against the
    wrong truth. A label names no record, so only the condition is compared; a number outside the catalogue passes."""
    if held not in DATA_CENTER_CATALOGUE:
        return
    catalogued = _parse_condition(DATA_CENTER_CATALOGUE[held][0])
    if (catalogued.fault, catalogued.load_hp, catalogued.fault_size_in, catalogued.position) != (
            label.fault, label.load_hp, label.fault_size_in, label.position):
        raise BearingTwinError(f"{path}: holds record {held}'s variables (X{held:03d}_*: {_catalogue_words(held)} in the "
                               f"Data Center's catalogue), while its name is the label {path.stem}: name the file by the "
                               "record it holds")


def _label_read_by_its_record(label: CwruName, held: int) -> tuple[CwruName, list[str]]:
    """A file named by a Data Center label (``IR007_0.mat``), read as the catalogued record whose variables it holds
    (``X278_*``: IR007_0 at 12 kHz, fan end), which names the rate and the faulty bearing's end that the label leaves
    unsaid (a mirror names the fan end's records by the same labels as the drive end's, in a folder of their own);
    the label as it is where the record is not catalogued or healthy (whose rate is in doubt)."""
    if held not in DATA_CENTER_CATALOGUE or label.fault == "normal":
        return label, []
    _, rate_hz, end = DATA_CENTER_CATALOGUE[held]
    return replace(label, record=held, rate_hz=rate_hz, end=end), [
        f"its variables are X{held:03d}_*, which the Data Center's catalogue lists as {_catalogue_words(held)}: read so"]


def _catalogue_disagrees(name: CwruName | None) -> list[str]:
    """A note where a long name gives a catalogued record another condition, rate or faulty bearing's end than the
    catalogue does (``12k_Drive_End_IR007_0_278.mat``: 278 is a fan-end record; ``12k_Drive_End_B007_0_105.mat``: 105
    is an inner-race one): read as the name says (the rate check checks its rate)."""
    if name is None or name.form != "long" or name.record not in DATA_CENTER_CATALOGUE or name.fault == "normal":
        return []
    label, rate_hz, end = DATA_CENTER_CATALOGUE[name.record]
    catalogued = _parse_condition(label)
    condition = (name.fault, name.load_hp, name.fault_size_in, name.position)
    if (rate_hz, end) == (name.rate_hz, name.end) and condition == (
            catalogued.fault, catalogued.load_hp, catalogued.fault_size_in, catalogued.position):
        return []
    code = {state: letters for letters, state in STATES.items()}[name.fault]
    says = (f"{code}{round(1000 * name.fault_size_in):03d}{'@' + name.position if name.position else ''}_{name.load_hp} "
            f"at {name.rate_hz / 1000:g} kHz, {name.end} end")
    return [f"the Data Center's catalogue lists record {name.record} as {_catalogue_words(name.record)}, where the name "
            f"says {says}: read as the name says; check which the file holds"]


def _name_notes(path: Path, name: CwruName | None, rpm: float | None) -> list[str]:
    """What a reader should know of a name: what a label or an uncatalogued number leaves unsaid, and a measured
    speed that belongs to another load than the name's."""
    notes = []
    read_as = ("read as a drive-end record declared at 12 kHz, the rate checked (channel=FE bearing=cwru_6203 for a "
               "fan-end record)")
    if name is None and path.stem.isdigit():
        notes.append(f"record {path.stem} is not in the Data Center's catalogue: {read_as}")
    elif name is not None and name.form == "label" and name.fault != "normal" and name.end is None:
        notes.append(f"the name {path.stem} (the Data Center's label) states no rate and no bearing end: {read_as}")
    nominal = NOMINAL_RPM_BY_LOAD_HP.get(name.load_hp) if name is not None else None
    if nominal is not None and rpm is not None and not same_speed(rpm, nominal):
        notes.append(f"its measured speed, {rpm:g} rpm, is not the Data Center's {nominal:g} rpm for the "
                     f"{name.load_hp} hp its name gives: read at the measured speed")
    return notes


def facts_from_long_name(raw: RawRecord) -> RawRecord:
    """``raw``, a file of another format than the Data Center's .mat (a record's samples saved as ``.npy``, ``.csv``,
    ``.wav``) under a CWRU long name (``12k_Drive_End_IR014_1_170.npy``, ``normal_0_97.csv``), with what that name
    says filled in where the file states none itself, as a .mat of that name is read: the state, the declared rate
    (checked like a .mat's), the Data Center's nominal speed for its load, its unit (g), the faulty bearing, the
    record's number, load, size and position. Other names, a number or a Data Center label alone, say too little of an unknown file to
    be read as CWRU's: it is returned as it is."""
    name = parse_cwru_name(raw.path)
    # A healthy record's name states no rate: only the Data Center's own numbers (97-100) make it CWRU's, not a
    # user's normal_0_1.csv.
    if name is None or name.form != "long" or (name.rate_hz is None and name.record not in DATA_CENTER_CATALOGUE):
        return raw
    taken = []
    if raw.fault is None:
        raw.fault = name.fault
        raw.meta["fault_from_name"] = True  # a label may speak of another bearing than the name, as for a .mat
        taken.append(f"state {name.fault}")
    if raw.fs is None:
        raw.fs, raw.fs_origin = (DECLARED_FS_HZ if name.rate_hz is None else name.rate_hz), "declared"
        if name.rate_hz is not None:
            raw.meta["named_rate"] = {"hz": name.rate_hz, "by": "its name states"}
        taken.append(f"rate {raw.fs / 1000:g} kHz (declared, checked)")
    nominal = NOMINAL_RPM_BY_LOAD_HP.get(name.load_hp)  # none for a load the Data Center never ran (4-9 hp)
    if raw.rpm is None and raw.nominal_rpm is None and nominal is not None:
        raw.nominal_rpm = nominal
        raw.nominal_rpm_note = f"speed {nominal:g} rpm: the Data Center's nominal speed at {name.load_hp} hp (the file states none)"
    if not raw.unit and not raw.channel_units:  # the Data Center's records are in g, as its .mat files say
        raw.unit = "g"
        taken.append("unit g")
    if name.end is not None and "bearing" not in raw.meta:
        raw.meta["bearing"] = name.bearing
        taken.append(f"the {name.end}-end bearing ({name.bearing})")
    raw.meta.update(record=name.record, load_hp=name.load_hp, fault_size_in=name.fault_size_in, position=name.position)
    if taken:
        raw.meta.setdefault("notes", []).append(f"read by its CWRU name: {', '.join(taken)}")
    return raw


def named_record(path: str | Path) -> int | None:
    """The record a file's name gives: the long form's (``..._0_130.mat``) or the Data Center's own number
    (``130.mat``, in its catalogue or not); None for a name that gives none (a Data Center label's)."""
    name = parse_cwru_name(path)
    stem = Path(path).stem
    return name.record if name is not None else (int(stem) if stem.isdigit() else None)


def declared_fs_hz(path: str | Path, default_hz: float, by_record: dict | None = None) -> float:
    """The sampling rate declared for the record at ``path``: its entry in ``by_record`` (record number -> Hz,
    ``data.fs_by_record``) if any, else the rate its name states (``48k_Drive_End_...``, or the Data Center's
    catalogue for a number-named file such as ``110.mat``, or for a label-named one the catalogued record whose
    variables it holds), else ``default_hz`` (``data.fs``; the healthy records' names state no rate)."""
    by_record = {int(key): float(value) for key, value in (by_record or {}).items()}
    record = named_record(path)
    if record in by_record:
        return by_record[record]
    name = parse_cwru_name(path)
    if name is not None and name.form == "label" and name.fault != "normal":  # as read_cwru_raw reads it
        name = _label_read_by_its_record(name, _held_record(path))[0]
    return float(default_hz) if name is None or name.rate_hz is None else float(name.rate_hz)


def _held_record(path: str | Path) -> int | None:
    """The record number of the one record whose variables a .mat file holds, read off their names alone
    (``scipy.io.whosmat``: no samples loaded); None where it holds several or none, or is no MATLAB 5 file."""
    import scipy.io

    try:
        numbers = {int(match[1]) for variable, *_ in scipy.io.whosmat(str(path)) if (match := _VARIABLE.match(variable))}
    except (OSError, ValueError, NotImplementedError, TypeError):  # absent, damaged, or MATLAB 7.3 (HDF5)
        return None
    return next(iter(numbers)) if len(numbers) == 1 else None


def load_cwru(
    path: str | Path,
    channel: str = "DE",
    fs: float | None = None,
    check_fs: bool = True,
    tolerance: float = 0.02,
    prominence: float = 20.0,
    bearing: BearingGeometry | None = None,
    remedy: str | None = None,
) -> Recording:
    """One channel of a CWRU record, its declared sampling rate checked against the shaft line.

    ``fs`` is the rate declared for this record (None: the data set's 12 kHz). All channels
    of a record share one rate, so every channel is a witness (each of the record's length: :func:`rate_witnesses`,
    as every command reads a file's channels): the rate stands if the shaft
    series confirms it in any of them (the fan-end channel of the fault records shows it only
    weakly). ``bearing`` (the record's bearing) adds its defect lines as a second witness,
    which tells a rate too low by a whole factor from real subharmonics. With ``check_fs`` a
    rate no channel supports raises, naming the rate the evidence implies and what to do (``remedy``: the
    caller's settings; by default ``data=cwru``'s); one the evidence cannot decide is logged and kept.
    """
    if channel not in CHANNELS:
        raise BearingTwinError(f"channel={channel!r} is not a CWRU channel; choose one of {', '.join(CHANNELS)}")
    raw = read_raw(path)
    if raw.format != "cwru-mat":
        raise BearingTwinError(f"{path}: not a CWRU record (no X<nnn>_DE_time / _FE_time / _BA_time variables)")
    recording = recording_from_raw(raw, channel=channel, fs=fs)
    if recording.rpm is None:
        raise BearingTwinError(f"{path}: no X<nnn>RPM variable and no motor load in the name, so the speed is unknown")
    for note in recording.meta["notes"]:
        log.warning("%s: %s", path, note)
    defect_hz = None if bearing is None else bearing.defect_frequencies(recording.rpm)
    checks = check_channels(rate_witnesses(recording.signal, raw.vibration_channels), recording.fs, recording.rpm, defect_hz=defect_hz, tolerance=tolerance,
                            prominence=prominence)
    witness = decisive_channel(checks)
    check = checks[witness]
    recording.meta["shaft_line"] = dict(check.as_dict(), channel=witness)
    if check_fs and check.verdict == "contradicted":
        remedy = remedy or (f"declare the record's rate (+data.fs_by_record.{recording.meta['record']}=<Hz>) "
                            "or set data.check_fs=false")
        raise BearingTwinError(f"{path}: {describe_mismatch(check)} (channel {witness}); {remedy}")
    if check_fs and check.verdict == "ambiguous":
        log.warning("%s: %s (channel %s)", path, describe_mismatch(check), witness)
    return recording
