"""Symbolic gestures over the bear's body (knight2009 V.E, Table I): locational filters + priority logic.

Filters and priorities live in ``config/bear_gestures.yaml`` (format documented there);
:class:`GestureLibrary` loads and checks it against the body map, :class:`SymbolicRecogniser` runs
it once per cycle and emits START / END events (msg/SymbolicGesture.msg) with the onset.

Per cycle, for every gesture ``g`` (all at once, as (G, 64) masks):

- a filter sensor *counts* when it is active and, if ``g`` requires subtypes, carries one of them;
- ``g`` *matches* when at least ``min_active`` sensors count (with ``both_sides``, one on each side);
- ``g`` is a *candidate* from its first match (its onset) while no lift between matches exceeds ``lift_s``
  (before START: the dwell goes on through a patting hand's lifts) or, once started, ``gap_s``;
- ``g`` is suppressed while a candidate that supersedes it is itself not suppressed (visited in
  topological order of "supersedes");
- START when a candidate, not suppressed, has ``t - onset >= dwell_s`` and matches now, or is in a
  lift after at least two separate contacts spanning half the dwell (a patting hand lifts between
  pats; at 3.4 Hz a dwell holds few touched scans); END when it stops being a candidate or becomes
  suppressed;
- a *brief* gesture (``max_s`` set, a shoulder tap) STARTs and ENDs when its candidate is released
  (no match for ``gap_s``: that joins the pats of a patting hand into one touch) after matching for
  between ``dwell_s`` and ``max_s`` seconds, with no other contact in its filter for ``quiet_s`` before
  its onset (a tap is isolated: the last pat of a slow series is not one); a longer touch never STARTs it.

Before START, a gesture whose filter is touched, not suppressed (brief: and quiet before), is announced
with CANDIDATE and a confidence (:class:`CandidateConfidence`); WITHDRAWN follows when it is superseded,
when nothing has held it for ``lift_s`` (brief: ``gap_s``), or (brief) when it matched longer than
``max_s``. A gesture that STARTs in the cycle it is first touched sends no CANDIDATE. Code that waits
for the decision reads START and END only.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from touch_driver.bear.body_map import BodyMap
from touch_graph.errors import ConfigError
from touch_graph.paths import share_file
from touch_graph.yamlconf import YamlDict, YamlList, check_keys, did_you_mean, load_yaml, loads_yaml, typed

from .candidates import CandidateConfidence
from .subtype_labels import SUBTYPES, TOUCH_SUBTYPES

__all__ = ['CANDIDATE', 'DECISIONS', 'DEFAULT_DWELL_S', 'DEFAULT_GAP_S', 'DEFAULT_LIFT_S', 'END', 'START',
           'STATE_NAMES', 'WITHDRAWN', 'CandidateConfidence', 'GestureFilter', 'GestureLibrary', 'SymbolicEvent',
           'SymbolicRecogniser']

#: "active for at least two seconds, an increment informally chosen to parallel human recognition time" (V.E).
DEFAULT_DWELL_S = 2.0
#: Not in the paper: tolerated dropout between matches of a started gesture before it ENDs.
DEFAULT_GAP_S = 1.5
#: Not in the paper: tolerated lift between matches before START, so pats and tickles do not restart the dwell.
DEFAULT_LIFT_S = DEFAULT_GAP_S
#: Event states, as in msg/SymbolicGesture.msg: START is the confirmed decision, END its end; CANDIDATE
#: and WITHDRAWN come before a decision (module doc).
START, END, CANDIDATE, WITHDRAWN = 1, 2, 3, 4
STATE_NAMES = {START: 'START', END: 'END', CANDIDATE: 'CANDIDATE', WITHDRAWN: 'WITHDRAWN'}
#: The states of the final decision (what behaviour code that waits for it reads).
DECISIONS = (START, END)
FORMAT_VERSION = 1

_NAME = re.compile(r'^[a-z][a-z0-9_]*$')
_GESTURE_KEYS = ('sensors', 'regions', 'min_active', 'dwell_s', 'lift_s', 'gap_s', 'max_s', 'quiet_s', 'both_sides',
                 'subtype',
                 'supersedes', 'detectable', 'table_i', 'paper', 'note')


@dataclass(frozen=True)
class GestureFilter:
    """One symbolic gesture: its locational filter, timing and priority.

    Attributes:
        name: identifier, e.g. ``'hug'``.
        channels: (k,) int wire channels of the filter (sensors plus expanded regions), sorted.
        sensor_names: the filter's sensor names, channel order.
        min_active: sensors that must count at once.
        dwell_s: seconds the filter must hold before START.
        gap_s: once started (brief: always), dropouts up to this long do not end the candidate, s.
        both_sides: require counting sensors on both the bear's left and right.
        subtypes: required subtypes (empty: any touch counts).
        supersedes: gestures suppressed while this one's filter holds.
        detectable: False for Table I gestures touch alone cannot tell (never reported).
        table_i: the name in knight2009 Table I.
        paper: one of the four the paper implemented.
        note: free text from the config.
        max_s: for a brief gesture, the longest it may match and still be it (None: no limit; module doc).
        lift_s: before START, lifts up to this long do not restart the dwell, s (brief gestures: ``gap_s``).
        quiet_s: for a brief gesture, how long its filter must have been untouched before its onset, s.
    """

    name: str
    channels: np.ndarray
    sensor_names: tuple[str, ...]
    min_active: int
    dwell_s: float
    gap_s: float
    both_sides: bool
    subtypes: tuple[str, ...]
    supersedes: tuple[str, ...]
    detectable: bool
    table_i: str
    paper: bool
    note: str
    max_s: float | None = None
    lift_s: float = DEFAULT_LIFT_S
    quiet_s: float = 0.0


@dataclass(frozen=True, slots=True)
class SymbolicEvent:
    """A gesture was announced, withdrawn, started or ended (msg/SymbolicGesture.msg).

    Attributes:
        gesture: gesture name.
        state: :data:`CANDIDATE`, :data:`WITHDRAWN`, :data:`START` or :data:`END`.
        t: cycle time of the event, s.
        onset: when the filter first matched (dwell start), s.
        duration_s: ``t - onset``.
        sensors: names of the filter's sensors counting at the event (at END: at the last match).
        reason: for END and WITHDRAWN, ``'released'``, ``'superseded by <name>'`` or (a brief gesture)
            ``'longer than max_s'``; empty otherwise.
        confidence: 0..1, the estimated probability that the gesture is (or was) confirmed: for a
            CANDIDATE from :class:`CandidateConfidence`; 1 for START and END, 0 for WITHDRAWN.
        evidence: for a CANDIDATE, its evidence level (:mod:`.candidates`): 0 a contact in the filter that
            does not match it yet, 1 a match, 2 a match with more sensors than ``min_active``; else 0.
    """

    gesture: str
    state: int
    t: float
    onset: float
    duration_s: float
    sensors: tuple[str, ...]
    reason: str = ''
    confidence: float = 1.0
    evidence: int = 0

    @property
    def state_name(self) -> str:
        return STATE_NAMES[self.state]


class GestureLibrary:
    """The gestures of a config file, checked against a body map, in priority (topological) order."""

    def __init__(self, gestures: Iterable[GestureFilter], source: str | None = None,
                 default_dwell_s: float = DEFAULT_DWELL_S, default_gap_s: float = DEFAULT_GAP_S,
                 default_lift_s: float = DEFAULT_LIFT_S) -> None:
        self.gestures: tuple[GestureFilter, ...] = tuple(gestures)
        self.source = source
        self.default_dwell_s = default_dwell_s
        self.default_gap_s = default_gap_s
        self.default_lift_s = default_lift_s
        self._by_name = {g.name: g for g in self.gestures}

    def __len__(self) -> int:
        return len(self.gestures)

    def __getitem__(self, name: str) -> GestureFilter:
        try:
            return self._by_name[name]
        except KeyError:
            raise KeyError(f'no gesture {name!r}{did_you_mean(name, self._by_name)}; the library '
                           f'({self.source}) has: {", ".join(self._by_name)}') from None

    def with_default_gap(self, gap_s: float) -> GestureLibrary:
        """A copy in which every gesture that used the default ``gap_s`` uses ``gap_s`` instead (a brief
        gesture's lift is its gap, so it follows)."""
        changed = [g if g.gap_s != self.default_gap_s else
                   replace(g, gap_s=gap_s, lift_s=gap_s) if g.max_s is not None else replace(g, gap_s=gap_s)
                   for g in self.gestures]
        return GestureLibrary(changed, self.source, self.default_dwell_s, gap_s, self.default_lift_s)

    def with_default_lift(self, lift_s: float) -> GestureLibrary:
        """A copy in which every gesture that used the default ``lift_s`` uses ``lift_s`` instead (brief
        gestures keep theirs: it is their ``gap_s``)."""
        changed = [replace(g, lift_s=lift_s) if g.max_s is None and g.lift_s == self.default_lift_s else g
                   for g in self.gestures]
        return GestureLibrary(changed, self.source, self.default_dwell_s, self.default_gap_s, lift_s)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self._by_name)

    @property
    def detectable(self) -> tuple[GestureFilter, ...]:
        """The gestures the recogniser runs, in priority order (supersessors first)."""
        return tuple(g for g in self.gestures if g.detectable)

    @classmethod
    def load(cls, path: str | Path, body_map: BodyMap | None = None) -> GestureLibrary:
        """Read a gesture YAML file; ConfigError with file:line (and a did-you-mean) on any problem."""
        return cls._from_doc(load_yaml(path), body_map, str(path))

    @classmethod
    def loads(cls, text: str, body_map: BodyMap | None = None, source: str = '<string>') -> GestureLibrary:
        """As :meth:`load`, from YAML text."""
        return cls._from_doc(loads_yaml(text, source), body_map, source)

    @classmethod
    def default(cls, body_map: BodyMap | None = None) -> GestureLibrary:
        """The package's ``config/bear_gestures.yaml``."""
        return cls.load(share_file('config', 'bear_gestures.yaml'), body_map)

    @classmethod
    def _from_doc(cls, doc: YamlDict, body_map: BodyMap | None, source: str) -> GestureLibrary:
        if body_map is None:
            body_map = BodyMap.default()
        check_keys(doc, required=('gestures',), optional=('format', 'defaults'), what='bear gesture library')
        version = typed(doc, 'format', int, 'bear gesture library', default=FORMAT_VERSION)
        if version != FORMAT_VERSION:
            raise doc.error(f'gesture library format {version} is not supported; this code reads format '
                            f'{FORMAT_VERSION}', 'format')
        defaults = doc.get('defaults', YamlDict())
        check_keys(defaults, optional=('dwell_s', 'lift_s', 'gap_s'), what='defaults')
        default_dwell = _non_negative(defaults, 'dwell_s', 'defaults', DEFAULT_DWELL_S)
        default_gap = _non_negative(defaults, 'gap_s', 'defaults', DEFAULT_GAP_S)
        default_lift = _non_negative(defaults, 'lift_s', 'defaults', DEFAULT_LIFT_S)
        items = doc['gestures']
        if not isinstance(items, YamlDict) or not items:
            raise doc.error('gestures must be a non-empty mapping: gesture name -> {sensors, min_active, ...}',
                            'gestures')
        parsed = {name: _parse_gesture(name, spec, items, body_map, default_dwell, default_gap, default_lift)
                  for name, spec in items.items()}
        for name, g in parsed.items():
            for i, other in enumerate(g.supersedes):
                where = items[name]['supersedes']
                if other not in parsed:
                    raise where.error(f"gesture '{name}' supersedes unknown gesture '{other}'"
                                      f'{did_you_mean(other, parsed)}; gestures are: {", ".join(parsed)}', i)
                if other == name:
                    raise where.error(f"gesture '{name}' cannot supersede itself", i)
        return cls(_priority_order(parsed, items), source, default_dwell, default_gap, default_lift)


def _non_negative(mapping, key: str, what: str, default: float) -> float:
    value = typed(mapping, key, float, what, default=default)
    if not math.isfinite(value) or value < 0:
        raise mapping.error(f"'{key}' in {what} must be a number of seconds >= 0; got {value!r}", key)
    return float(value)


def _string_list(spec, key: str, what: str) -> YamlList:
    value = spec[key]
    if isinstance(value, str):
        out = YamlList([value])
        out.path, out.line, out.item_lines = spec.path, spec.line_of(key), [spec.line_of(key)]
        return out
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise spec.error(f"'{key}' in {what} must be a name or a list of names; got {value!r}", key)
    return value


def _parse_gesture(name, spec, items, body_map: BodyMap, default_dwell: float, default_gap: float,
                   default_lift: float) -> GestureFilter:
    what = f"gesture '{name}'"
    if not isinstance(name, str) or not _NAME.match(name):
        raise items.error(f'gesture name {name!r} must be lower case letters, digits and _ (e.g. head_pat)', name)
    if not isinstance(spec, YamlDict):
        raise items.error(f'{what} must be a mapping with keys {", ".join(_GESTURE_KEYS)}; got {spec!r}', name)
    check_keys(spec, optional=_GESTURE_KEYS, what=what)
    detectable = typed(spec, 'detectable', bool, what, default=True)
    note = typed(spec, 'note', str, what, default='')
    table_i = typed(spec, 'table_i', str, what, default='')
    paper = typed(spec, 'paper', bool, what, default=False)
    if not detectable:
        if not note:
            raise spec.error(f"{what} is marked detectable: false; add a 'note' saying what touch alone cannot "
                             'tell and which sensing it would need', 'detectable')
        return GestureFilter(name, np.zeros(0, dtype=np.intp), (), 1, default_dwell, default_gap, False, (), (),
                             False, table_i, paper, note)

    channels: dict[int, str] = {}
    region_names = _regions_of(body_map)
    if 'sensors' in spec:
        names = _string_list(spec, 'sensors', what)
        for i, sensor in enumerate(names):
            try:
                channels[int(body_map.by_name(sensor).channel)] = sensor
            except ConfigError:
                hint = did_you_mean(sensor, [s.name for s in body_map.sensors])
                if sensor in region_names:
                    hint = f" ('{sensor}' is a region: list it under 'regions')"
                raise names.error(f"{what}: unknown sensor '{sensor}'{hint}; sensors are named in the body map "
                                  f'({getattr(body_map, "source", None) or "config/bear_body.yaml"})', i) from None
    if 'regions' in spec:
        regions = _string_list(spec, 'regions', what)
        for i, region in enumerate(regions):
            members = [s for s in body_map.sensors if s.region == region]
            if not members:
                raise regions.error(f"{what}: unknown region '{region}'{did_you_mean(region, region_names)}; "
                                    f'regions with sensors are: {", ".join(sorted(region_names))}', i)
            channels.update({int(s.channel): s.name for s in members})
    if not channels:
        raise spec.error(f"{what} needs a locational filter: 'sensors' and/or 'regions' (or detectable: false "
                         'with a note)')
    order = sorted(channels)
    min_active = typed(spec, 'min_active', int, what, default=1)
    if not 1 <= min_active <= len(order):
        raise spec.error(f'{what}: min_active must be 1..{len(order)} (the filter has {len(order)} sensors); '
                         f'got {min_active}', 'min_active')
    both_sides = typed(spec, 'both_sides', bool, what, default=False)
    if both_sides:
        sides = {body_map.by_channel(c).side for c in order}
        if not {'left', 'right'} <= sides:
            raise spec.error(f'{what}: both_sides needs filter sensors on the left and on the right; the filter '
                             f'has sides {sorted(sides)}', 'both_sides')
    subtypes: tuple[str, ...] = ()
    if 'subtype' in spec:
        listed = _string_list(spec, 'subtype', what)
        for i, sub in enumerate(listed):
            if sub not in TOUCH_SUBTYPES:
                raise listed.error(f"{what}: unknown subtype '{sub}'{did_you_mean(sub, TOUCH_SUBTYPES)}; "
                                   f'subtypes are: {", ".join(TOUCH_SUBTYPES)}', i)
        subtypes = tuple(listed)
    supersedes = tuple(_string_list(spec, 'supersedes', what)) if 'supersedes' in spec else ()
    dwell = _non_negative(spec, 'dwell_s', what, default_dwell)
    max_s = _non_negative(spec, 'max_s', what, 0.0) if 'max_s' in spec else None
    if max_s is not None and max_s < dwell:
        raise spec.error(f'{what}: max_s ({max_s} s) must be at least dwell_s ({dwell} s)', 'max_s')
    gap = _non_negative(spec, 'gap_s', what, default_gap)
    if max_s is None and 'quiet_s' in spec:
        raise spec.error(f'{what}: quiet_s is for brief gestures (with max_s): how long the filter must be '
                         'untouched before one', 'quiet_s')
    if max_s is not None and 'lift_s' in spec:
        raise spec.error(f'{what}: a brief gesture (max_s) joins its contacts with gap_s; lift_s is the tolerated '
                         'lift in the dwell of the others', 'lift_s')
    lift = gap if max_s is not None else _non_negative(spec, 'lift_s', what, default_lift)
    quiet = _non_negative(spec, 'quiet_s', what, 0.0)
    return GestureFilter(name, np.array(order, dtype=np.intp), tuple(channels[c] for c in order), min_active,
                         dwell, gap, both_sides, subtypes, supersedes, True, table_i, paper, note, max_s, lift, quiet)


def _regions_of(body_map: BodyMap) -> set[str]:
    return {s.region for s in body_map.sensors}


def _priority_order(parsed: dict[str, GestureFilter], items: YamlDict) -> list[GestureFilter]:
    """Kahn's topological sort of "supersedes" (supersessors first, config order among equals)."""
    incoming = {name: 0 for name in parsed}
    for g in parsed.values():
        for other in g.supersedes:
            incoming[other] += 1
    ready = [n for n in parsed if incoming[n] == 0]
    out: list[GestureFilter] = []
    while ready:
        name = ready.pop(0)
        out.append(parsed[name])
        for other in parsed[name].supersedes:
            incoming[other] -= 1
            if incoming[other] == 0:
                ready.append(other)
    if len(out) < len(parsed):
        stuck = [n for n in parsed if incoming[n] > 0]
        raise items[stuck[0]].error(f'supersedes relations form a cycle among: {", ".join(stuck)}; priority logic '
                                    'needs an order, so remove one relation', 'supersedes')
    return out


class SymbolicRecogniser:
    """Runs a :class:`GestureLibrary` once per cycle and emits CANDIDATE / WITHDRAWN / START / END events.

    Args:
        library: the gestures (default: ``config/bear_gestures.yaml``).
        body_map: the body map (default: the package's); gives the sides for ``both_sides``.
        n_channels: wire channels.
        confidence: the CANDIDATE confidences (default: ``config/bear_candidates.yaml``).
    """

    def __init__(self, library: GestureLibrary | None = None, body_map: BodyMap | None = None,
                 n_channels: int = 64, confidence: CandidateConfidence | None = None) -> None:
        if body_map is None:
            body_map = BodyMap.default()
        self.library = library if library is not None else GestureLibrary.default(body_map)
        self.confidence = confidence if confidence is not None else CandidateConfidence.default()
        self.gestures = self.library.detectable
        names = [g.name for g in self.gestures]
        index = {n: i for i, n in enumerate(names)}
        G = len(self.gestures)
        self._member = np.zeros((G, n_channels), dtype=bool)
        self._allowed = np.ones((G, len(SUBTYPES)), dtype=bool)
        for i, g in enumerate(self.gestures):
            self._member[i, g.channels] = True
            if g.subtypes:
                self._allowed[i] = [s in g.subtypes for s in SUBTYPES]
        self._left = np.zeros(n_channels, dtype=bool)
        self._right = np.zeros(n_channels, dtype=bool)
        for s in body_map.sensors:
            self._left[s.channel] = s.side == 'left'
            self._right[s.channel] = s.side == 'right'
        self._min_active = np.array([g.min_active for g in self.gestures], dtype=np.int64)
        self._both = np.array([g.both_sides for g in self.gestures], dtype=bool)
        self._needs_subtype = np.array([bool(g.subtypes) for g in self.gestures], dtype=bool)
        # superseded_by[i]: indices of detectable gestures that supersede gesture i
        self._superseded_by = [[index[h.name] for h in self.gestures if g.name in h.supersedes] for g in self.gestures]
        self._names_by_channel = {s.channel: s.name for s in body_map.sensors}
        self.n_channels = n_channels
        self.reset()

    def reset(self) -> None:
        G = len(self.gestures)
        #: per gesture: time the filter first matched (None: not a candidate), s
        self.onset: list[float | None] = [None] * G
        #: per gesture: time of the latest match, s
        self.last_match: list[float | None] = [None] * G
        #: per gesture: START sent and no END yet
        self.started: list[bool] = [False] * G
        self._start_onset = [0.0] * G                     # onset of the started episode (for its END)
        self._last_counting: list[np.ndarray | None] = [None] * G   # counting sensors at the latest match
        #: per gesture: a CANDIDATE is out (no START nor WITHDRAWN since)
        self.announced: list[bool] = [False] * G
        self._announced_onset = [0.0] * G                 # onset of the announced candidate (for its WITHDRAWN)
        self._contacts = [0] * G                          # separate contacts (matches after a lift) since onset
        self._previous_t: float | None = None             # the previous cycle's time
        self._last_touch = [-math.inf] * G                # time of the latest contact in the filter, s
        self._spent = [False] * G           # a brief gesture held past max_s: not announced again until released
        self._quiet = [True] * G            # a brief gesture's episode began quiet_s or more after a contact

    def _sensor_names(self, i: int) -> tuple[str, ...]:
        row = self._last_counting[i]
        if row is None:
            return ()
        return tuple(self._names_by_channel.get(int(c), str(c)) for c in np.flatnonzero(row))

    def active_gestures(self) -> dict[str, float]:
        """Gesture name -> onset (s) of the gestures started and not ended."""
        return {g.name: float(self._start_onset[i]) for i, g in enumerate(self.gestures) if self.started[i]}

    def announced_gestures(self) -> dict[str, float]:
        """Gesture name -> onset (s) of the CANDIDATEs out (neither confirmed nor withdrawn)."""
        return {g.name: float(self._announced_onset[i]) for i, g in enumerate(self.gestures) if self.announced[i]}

    def update(self, t: float, active: np.ndarray, subtype_codes: np.ndarray | None = None) -> list[SymbolicEvent]:
        """One cycle.

        Args:
            t: cycle time, s (non-decreasing).
            active: (64,) bool, sensors at or above the activation threshold.
            subtype_codes: (64,) int codes into SUBTYPES (needed only by gestures that require subtypes;
                None means no subtype is known, so such gestures never match).

        Returns:
            The events of this cycle: ENDs and WITHDRAWNs first (in priority order), then STARTs and
            CANDIDATEs.
        """
        active = np.asarray(active, dtype=bool)
        self._touch_row = self._member & active[None, :]
        counting = self._touch_row.copy()
        if self._needs_subtype.any():
            if subtype_codes is None:
                counting[self._needs_subtype] = False
            else:
                codes = np.clip(np.asarray(subtype_codes, dtype=np.intp), 0, len(SUBTYPES) - 1)
                counting &= self._allowed[:, codes]
        counts = counting.sum(axis=1)
        sides_ok = ~self._both | ((counting & self._left).any(axis=1) & (counting & self._right).any(axis=1))
        matched = (counts >= self._min_active) & sides_ok

        touched = (self._member & active[None, :]).any(axis=1)   # contact in the filter, matched or not
        # The state machine runs on Python lists: scalar numpy indexing would cost more than the maths.
        matched_l, touched_l = matched.tolist(), touched.tolist()
        counts_l = counts.tolist()
        onset, last, started, announced = self.onset, self.last_match, self.started, self.announced
        ends: list[SymbolicEvent] = []
        starts: list[SymbolicEvent] = []
        live = [False] * len(self.gestures)          # candidate and not suppressed
        for i, g in enumerate(self.gestures):        # priority order: supersessors are decided first
            touched_before = self._last_touch[i]
            if touched_l[i]:
                self._last_touch[i] = t
            if matched_l[i]:
                if onset[i] is None:
                    onset[i] = t
                    self._contacts[i] = 0
                    self._quiet[i] = t - touched_before >= g.quiet_s - 1e-9
                if last[i] != self._previous_t:     # a new contact after a lift
                    self._contacts[i] += 1
                last[i] = t
                self._last_counting[i] = counting[i]
            elif last[i] is not None and t - last[i] > (g.gap_s if started[i] else g.lift_s) + 1e-9:   # 1e-9: float
                if g.max_s is not None and self._quiet[i] and not self._suppressed(i, live) and \
                        g.dwell_s <= last[i] - onset[i] <= g.max_s + 1e-9:
                    announced[i] = False
                    starts += self._brief(g, i, t, onset[i])
                onset[i] = last[i] = None
                self._spent[i] = False
            by = [h for h in self._superseded_by[i] if live[h]]
            live[i] = onset[i] is not None and not by
            # A CANDIDATE out is withdrawn when superseded, or once neither a match nor a contact holds it.
            released = onset[i] is None and t - self._last_touch[i] > g.lift_s + 1e-9
            if g.max_s is not None:                  # brief gestures START only at their release (above)
                if announced[i] and (by or released or last[i] - onset[i] > g.max_s + 1e-9):
                    reason = (f'superseded by {self.gestures[by[0]].name}' if by else 'released' if released
                              else 'longer than max_s')
                    ends.append(self._withdrawn(i, t, reason))
                    self._spent[i] = not by and not released   # held too long: not a tap until released
                elif touched_l[i] and not by and not announced[i] and not self._spent[i] and (
                        self._quiet[i] if onset[i] is not None else t - touched_before >= g.quiet_s - 1e-9):
                    starts.append(self._candidate(g, i, t, matched_l[i], counts_l[i]))
                continue
            if started[i] and not live[i]:
                reason = f'superseded by {self.gestures[by[0]].name}' if by else 'released'
                begin = self._start_onset[i]
                ends.append(SymbolicEvent(g.name, END, t, begin, t - begin, self._sensor_names(i), reason))
                started[i] = False
            elif not started[i] and live[i] and t - onset[i] >= g.dwell_s and (matched_l[i] or (
                    self._contacts[i] >= 2 and last[i] - onset[i] >= g.dwell_s / 2)):   # in a lift: module doc
                started[i] = True
                announced[i] = False
                self._start_onset[i] = onset[i]
                starts.append(SymbolicEvent(g.name, START, t, onset[i], t - onset[i], self._sensor_names(i)))
            elif announced[i] and (by or released):
                ends.append(self._withdrawn(i, t, f'superseded by {self.gestures[by[0]].name}' if by else 'released'))
            elif touched_l[i] and not by and not started[i] and not announced[i]:
                starts.append(self._candidate(g, i, t, matched_l[i], counts_l[i]))
        self._previous_t = t
        return ends + starts

    def _candidate(self, g: GestureFilter, i: int, t: float, matched: bool, count: int) -> SymbolicEvent:
        """Announce gesture ``i`` (module doc), with the confidence of its evidence."""
        self.announced[i] = True
        evidence = 1 + min(count - g.min_active, 1) if matched else 0
        onset = self._announced_onset[i] = self.onset[i] if matched else t
        sensors = self._sensor_names(i) if matched else self._touched_names(i)
        return SymbolicEvent(g.name, CANDIDATE, t, onset, t - onset, sensors,
                             confidence=self.confidence.confidence(g.name, evidence), evidence=evidence)

    def _touched_names(self, i: int) -> tuple[str, ...]:
        return tuple(self._names_by_channel.get(int(c), str(c)) for c in np.flatnonzero(self._touch_row[i]))

    def _withdrawn(self, i: int, t: float, reason: str) -> SymbolicEvent:
        self.announced[i] = False
        onset = self._announced_onset[i]
        return SymbolicEvent(self.gestures[i].name, WITHDRAWN, t, onset, t - onset, self._sensor_names(i), reason,
                             confidence=0.0)

    def _suppressed(self, i: int, live: list[bool]) -> bool:
        return any(live[h] for h in self._superseded_by[i])

    def _brief(self, g: GestureFilter, i: int, t: float, onset: float) -> list[SymbolicEvent]:
        """START and END of brief gesture ``i``, released at ``t`` (module doc)."""
        names = self._sensor_names(i)
        return [SymbolicEvent(g.name, START, t, onset, t - onset, names),
                SymbolicEvent(g.name, END, t, onset, t - onset, names, 'released')]
