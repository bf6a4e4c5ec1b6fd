"""Pose streams from ROS bags: ROS 1 ``.bag`` files and ROS 2 bags (sqlite3 or MCAP), read
with the pure-Python ``rosbags`` package (no ROS install).

    from simcalib.ros.bag import read_bag_streams, list_bag
    print(list_bag("run.bag"))                     # topics, tf frames and edges
    a, b = read_bag_streams("run.bag", "/tf:base_link->tool0", "/tf:board->camera_link")

A bag is not a text pose file, so this is a separate entry point next to the format registry
(:mod:`simcalib.importers`); its streams are the same validated
:class:`~simcalib.importers.PoseStreamData` (``format`` ``"rosbag"``), so everything
downstream (conventions, clock offset, solvers) treats them like any other stream.

A *spec* names one stream:

* ``/tf:PARENT->CHILD`` (also ``tf:PARENT->CHILD``): the pose ``T_PARENT_CHILD`` composed
  through the tf tree (every ``tf2_msgs/TFMessage`` topic; topics whose name ends in
  ``tf_static`` are static) along the path PARENT -> common ancestor -> CHILD, so either
  direction of an edge can be asked for. The stream's stamps are those of the moving
  (non-static) edges on that path: their union, restricted to the span where every moving
  edge has data; a moving edge without a message at one of those stamps is interpolated the
  way tf2 does (translation linear, rotation slerp). When the moving edges are published
  together (robot_state_publisher: one stamp for every joint) no interpolation happens.
  Static edges are applied as they are. A path with no moving edge is an error (a constant
  pose is no stream).
* a topic name of ``geometry_msgs/PoseStamped``, ``geometry_msgs/PoseWithCovarianceStamped``,
  ``nav_msgs/Odometry`` or ``geometry_msgs/TransformStamped``: the pose in the header's
  ``frame_id`` (``T_frame_id_child``).

Stamps are the messages' header stamps (``sec + nanosec / 1e9``, float seconds), never the
bag's record time. Frame names are compared without a leading ``/`` (tf2 drops it too).
Bad bags, unknown topics or frames, unconnected chains and unsupported topic types raise
:class:`simcalib.errors.DataError` listing what the bag holds.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from simcalib.errors import DataError, did_you_mean
from simcalib.geometry import (invert_transform, matrix_from_quat, matrix_from_rotvec,
                               rotvec_from_matrix, transform_from_rotation_translation)
from simcalib.importers import PoseStreamData, stream_from_arrays

__all__ = ["BagSpec", "BagStream", "BagStreams", "TopicSummary", "EdgeSummary", "BagSummary",
           "parse_spec", "read_bag", "read_bag_streams", "read_bag_stream", "describe_bag",
           "list_bag", "stamp_seconds", "export_frames", "spec_frames", "TF_TYPES",
           "POSE_TYPES", "FORMAT"]

FORMAT = "rosbag"
TF_PREFIXES = ("/tf:", "tf:")
TF_TYPES = ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage")
#: message type -> attribute path to a Pose (position + orientation) or a Transform
POSE_TYPES = {
    "geometry_msgs/msg/PoseStamped": ("pose",),
    "geometry_msgs/msg/PoseWithCovarianceStamped": ("pose", "pose"),
    "nav_msgs/msg/Odometry": ("pose", "pose"),
    "geometry_msgs/msg/TransformStamped": ("transform",),
}
SPEC_FORMS = ("'/tf:PARENT->CHILD'", "a topic of " + ", ".join(
    t.replace("/msg/", "/") for t in POSE_TYPES))


# ------------------------------------------------------------------------------ specs
@dataclass(frozen=True)
class BagSpec:
    """A parsed stream spec: ``kind`` ``"tf"`` (with ``parent``, ``child``) or ``"topic"``
    (with ``topic``); ``text`` the spec as given."""
    kind: str
    text: str
    parent: str = ""
    child: str = ""
    topic: str = ""


def _frame(name: str) -> str:
    return name.strip().lstrip("/")


def parse_spec(spec: str) -> BagSpec:
    """``"/tf:base_link->tool0"`` -> tf spec; anything else naming a topic -> topic spec.
    Raises DataError for an empty spec or a tf spec without two frames."""
    if not isinstance(spec, str) or not spec.strip():
        raise DataError(f"bag stream spec must be {' or '.join(SPEC_FORMS)}; "
                        f"received {spec!r}")
    s = spec.strip()
    for prefix in TF_PREFIXES:
        if s.startswith(prefix):
            body = s[len(prefix):]
            parts = body.split("->")
            if len(parts) != 2 or not _frame(parts[0]) or not _frame(parts[1]):
                raise DataError(f"tf spec must be '/tf:PARENT->CHILD' with two frame names; "
                                f"received {spec!r}")
            parent, child = _frame(parts[0]), _frame(parts[1])
            if parent == child:
                raise DataError(f"tf spec {spec!r} names the same frame twice; the pose of a "
                                "frame in itself is the identity, not a stream")
            return BagSpec("tf", s, parent=parent, child=child)
    return BagSpec("topic", s, topic=s)


# ---------------------------------------------------------------------------- results
@dataclass(frozen=True)
class BagStream:
    """One stream read from a bag: ``stream`` (the poses; ``T_world_sensor`` is
    ``T_parent_child``), ``parent`` / ``child`` its frames (``child`` is ``""`` for a
    PoseStamped topic, which names no child frame), ``spec`` the parsed spec, ``moving_edges``
    (tf) the moving edges it was composed from, ``interpolated`` how many of its poses needed
    an interpolated edge."""
    stream: PoseStreamData
    parent: str
    child: str
    spec: BagSpec
    moving_edges: tuple = ()
    interpolated: int = 0


@dataclass(frozen=True)
class BagStreams:
    """The two streams of :func:`read_bag`, ``a`` and ``b``, and the bag's ``path``."""
    path: str
    a: BagStream
    b: BagStream


@dataclass(frozen=True)
class TopicSummary:
    name: str
    msgtype: str
    count: int


@dataclass(frozen=True)
class EdgeSummary:
    """A tf edge ``parent -> child``: static or moving, its message count and stamp span."""
    parent: str
    child: str
    static: bool
    count: int
    first_s: float
    last_s: float


@dataclass(frozen=True)
class BagSummary:
    """What :func:`describe_bag` found: the bag's ``kind`` (``ROS 1``, ``ROS 2 sqlite3``,
    ``ROS 2 mcap``), topics, tf edges and the stamp span of its records."""
    path: str
    kind: str
    topics: tuple
    edges: tuple
    duration_s: float
    messages: int

    def format(self) -> str:
        lines = [f"{self.path}: {self.kind} bag, {self.messages} messages over "
                 f"{self.duration_s:.3f} s (record time)", "topics:"]
        w = max([len(t.name) for t in self.topics] + [5])
        wt = max([len(_short(t.msgtype)) for t in self.topics] + [4])
        for t in self.topics:
            usable = ("  <- usable as a stream spec" if t.msgtype in POSE_TYPES else
                      "  (tf)" if t.msgtype in TF_TYPES else "")
            lines.append(f"  {t.name:<{w}}  {_short(t.msgtype):<{wt}}  {t.count:>6}{usable}")
        if not self.topics:
            lines.append("  (none)")
        lines.append("tf edges (parent -> child):")
        for e in self.edges:
            kind = "static" if e.static else (f"moving, {e.count} stamps "
                                             f"{e.first_s:.3f} .. {e.last_s:.3f} s")
            lines.append(f"  {e.parent} -> {e.child}  ({kind})")
        if not self.edges:
            lines.append("  (none: no tf2_msgs/TFMessage topic)")
        else:
            lines.append("tf trees: " + "; ".join(
                f"root {r}: {', '.join(fr)}" for r, fr in _trees(
                    {e.child: e.parent for e in self.edges}).items()))
            lines.append("streams: a=/tf:PARENT->CHILD between two frames of one tree")
        return "\n".join(lines) + "\n"


def _short(msgtype: str) -> str:
    return msgtype.replace("/msg/", "/")


# ------------------------------------------------------------------------ bag reading
def stamp_seconds(sec, nanosec) -> np.ndarray:
    """Header stamps ``(sec, nanosec)`` as float seconds: ``sec + nanosec / 1e9``."""
    return (np.asarray(sec, dtype=np.int64).astype(np.float64)
            + np.asarray(nanosec, dtype=np.int64).astype(np.float64) / 1e9)


def _open(path):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore
    p = Path(path)
    if not p.exists():
        raise DataError(f"bag {str(path)!r} does not exist")
    allowed = ("a ROS 1 .bag file, a ROS 2 bag directory (with metadata.yaml) or a ROS 2 "
               ".mcap / .db3 file")
    try:
        reader = AnyReader([p], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as exc:  # noqa: BLE001 - rosbags raises several unrelated types
        raise DataError(f"{str(p)!r} is not a readable bag ({type(exc).__name__}: {exc}); "
                        f"allowed: {allowed}") from None
    return reader


def _kind(reader, p: Path) -> str:
    if not reader.is2:
        return "ROS 1"
    names = [f.suffix for f in p.iterdir()] if p.is_dir() else [p.suffix]
    storage = "mcap" if ".mcap" in names else "sqlite3" if ".db3" in names else "unknown"
    return f"ROS 2 {storage}"


def _topics(reader) -> dict:
    out: dict[str, TopicSummary] = {}
    for c in reader.connections:
        prev = out.get(c.topic)
        n = int(c.msgcount) + (prev.count if prev else 0)
        out[c.topic] = TopicSummary(c.topic, c.msgtype, n)
    return out


def _messages(reader, topics):
    conns = [c for c in reader.connections if c.topic in topics]
    for conn, _t, raw in reader.messages(connections=conns):
        yield conn, reader.deserialize(raw, conn.msgtype)


def _ns(stamp) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _pose_row(obj) -> tuple:
    """``(x, y, z, qx, qy, qz, qw)`` of a geometry_msgs Pose (position/orientation) or
    Transform (translation/rotation)."""
    p = obj.position if hasattr(obj, "position") else obj.translation
    q = obj.orientation if hasattr(obj, "orientation") else obj.rotation
    return (p.x, p.y, p.z, q.x, q.y, q.z, q.w)


def _matrices(rows) -> np.ndarray:
    """(N, 4, 4) from rows of :func:`_pose_row` (one batched conversion)."""
    a = np.asarray(rows, dtype=np.float64).reshape(-1, 7)
    return transform_from_rotation_translation(matrix_from_quat(a[:, 3:]), a[:, :3])


# ------------------------------------------------------------------------------- tf
@dataclass(frozen=True)
class _Edge:
    parent: str
    child: str
    static: bool
    stamps_ns: np.ndarray = field(repr=False)
    T: np.ndarray = field(repr=False)
    duplicates: int = 0


def _load_tf(reader, topics: dict) -> dict[str, _Edge]:
    """child -> edge, from every TFMessage topic. A frame with two parents is an error."""
    tf_topics = [t.name for t in topics.values() if t.msgtype in TF_TYPES]
    acc: dict[str, dict] = {}
    for conn, msg in _messages(reader, tf_topics):
        static = conn.topic.rstrip("/").endswith("tf_static")
        for tr in msg.transforms:
            parent, child = _frame(tr.header.frame_id), _frame(tr.child_frame_id)
            e = acc.setdefault(child, {"parent": parent, "static": [], "moving": []})
            if e["parent"] != parent:
                raise DataError(
                    f"tf frame {child!r} has two parents in the bag ({e['parent']!r} and "
                    f"{parent!r}, topic {conn.topic}); a tf tree gives each frame one parent")
            e["static" if static else "moving"].append((_ns(tr.header.stamp),
                                                        _pose_row(tr.transform)))
    return {child: _edge(child, e) for child, e in acc.items()}


def _edge(child: str, e: dict) -> _Edge:
    rows = e["moving"] or e["static"][-1:]      # a moving edge ignores stale static values
    stamps = np.array([r[0] for r in rows], dtype=np.int64)
    T = _matrices([r[1] for r in rows])
    order = np.argsort(stamps, kind="stable")
    stamps, T = stamps[order], T[order]
    keep = np.concatenate([[True], np.diff(stamps) != 0])
    return _Edge(e["parent"], child, not e["moving"], stamps[keep], T[keep],
                 int((~keep).sum()))


def _trees(parent_of: dict) -> dict[str, list[str]]:
    """root -> frames (sorted) of every tree of a child -> parent map."""
    frames = set(parent_of) | set(parent_of.values())
    out: dict[str, list[str]] = {}
    for f in sorted(frames):
        out.setdefault(_ancestors(f, parent_of)[-1], []).append(f)
    return out


def _ancestors(frame: str, parent_of: dict) -> list[str]:
    chain = [frame]
    while chain[-1] in parent_of:
        nxt = parent_of[chain[-1]]
        if nxt in chain:
            raise DataError(f"tf frames form a loop: {' -> '.join(chain + [nxt])}")
        chain.append(nxt)
    return chain


def _chain(edges: dict[str, _Edge], parent: str, child: str, spec: str, path: str):
    """The edges from ``parent`` to ``child``: ``[(edge, +1 down / -1 up), ...]`` in
    composition order."""
    parent_of = {c: e.parent for c, e in edges.items()}
    frames = sorted(set(parent_of) | set(parent_of.values()))
    for f in (parent, child):
        if f not in frames:
            raise DataError(f"{path}: tf frame {f!r} of {spec!r} is not in the bag"
                            f"{did_you_mean(f, frames)}; frames: "
                            f"{', '.join(frames) or '(none: no tf topic)'}")
    up, down = _ancestors(parent, parent_of), _ancestors(child, parent_of)
    common = next((f for f in up if f in down), None)
    if common is None:
        trees = _trees(parent_of)
        raise DataError(
            f"{path}: {spec!r} is not connected: {parent!r} is in the tf tree rooted at "
            f"{up[-1]!r}, {child!r} in the tree rooted at {down[-1]!r}; trees: " + "; ".join(
                f"{r}: {', '.join(fr)}" for r, fr in trees.items()))
    steps = [(edges[f], -1) for f in up[:up.index(common)]]
    steps += [(edges[f], +1) for f in reversed(down[:down.index(common)])]
    return steps


def _interpolate(edge: _Edge, q_ns: np.ndarray) -> tuple[np.ndarray, int]:
    """Edge poses at stamps ``q_ns`` (inside its span): exact where a stamp matches, else
    translation linear and rotation slerp between the neighbours (as tf2)."""
    s = edge.stamps_ns
    k = np.searchsorted(s, q_ns, side="left")
    exact = (k < s.size) & (s[np.minimum(k, s.size - 1)] == q_ns)
    out = edge.T[np.minimum(k, s.size - 1)].copy()
    need = ~exact
    if need.any():
        k1 = k[need]
        k0 = k1 - 1
        u = ((q_ns[need] - s[k0]).astype(np.float64) / (s[k1] - s[k0]).astype(np.float64))
        T0, T1 = edge.T[k0], edge.T[k1]
        R0 = T0[:, :3, :3]
        dR = np.swapaxes(R0, 1, 2) @ T1[:, :3, :3]
        R = R0 @ matrix_from_rotvec(rotvec_from_matrix(dR) * u[:, None])
        t = T0[:, :3, 3] + u[:, None] * (T1[:, :3, 3] - T0[:, :3, 3])
        out[need] = transform_from_rotation_translation(R, t)
    return out, int(need.sum())


def _tf_stream(edges, spec: BagSpec, path: str) -> BagStream:
    steps = _chain(edges, spec.parent, spec.child, spec.text, path)
    moving = [e for e, _ in steps if not e.static]
    if not moving:
        raise DataError(f"{path}: every tf edge from {spec.parent!r} to {spec.child!r} is "
                        f"static ({', '.join(f'{e.parent}->{e.child}' for e, _ in steps)}); "
                        "a pose stream needs a moving edge on the chain")
    lo = max(int(e.stamps_ns[0]) for e in moving)
    hi = min(int(e.stamps_ns[-1]) for e in moving)
    stamps = np.unique(np.concatenate([e.stamps_ns for e in moving]))
    stamps = stamps[(stamps >= lo) & (stamps <= hi)]
    if stamps.size == 0:
        raise DataError(f"{path}: the moving tf edges of {spec.text!r} "
                        f"({', '.join(f'{e.parent}->{e.child}' for e in moving)}) have no "
                        "common time span")
    T = np.broadcast_to(np.eye(4), (stamps.size, 4, 4)).copy()
    n_interp = np.zeros(stamps.size, dtype=bool)
    for e, direction in steps:
        if e.static:
            E = np.broadcast_to(e.T[0], T.shape)
        else:
            E, _ = _interpolate(e, stamps)
            n_interp |= ~np.isin(stamps, e.stamps_ns)
        T = T @ (E if direction > 0 else invert_transform(E))
    ns = stamps.astype(np.int64)
    t = stamp_seconds(ns // 1_000_000_000, ns % 1_000_000_000)
    s = stream_from_arrays(t, T, source=f"{path}", name=spec.text, quat_order="xyzw")
    repairs = dict(s.repairs)
    dup = sum(e.duplicates for e in moving)
    if dup:
        repairs["tf_duplicate_stamps_dropped"] = dup
    if n_interp.any():
        repairs["tf_edges_interpolated"] = int(n_interp.sum())
    detail = (f"tf chain {', '.join(_step_text(e, d) for e, d in steps)}; stamps of the "
              f"moving edges {', '.join(f'{e.parent}->{e.child}' for e in moving)}")
    s = replace(s, format=FORMAT, detection=detail, repairs=repairs)
    return BagStream(s, spec.parent, spec.child, spec,
                     tuple(f"{e.parent}->{e.child}" for e in moving), int(n_interp.sum()))


def _step_text(e: _Edge, direction: int) -> str:
    arrow = f"{e.parent}->{e.child}" if direction > 0 else f"({e.parent}->{e.child})^-1"
    return arrow + (" static" if e.static else "")


# ----------------------------------------------------------------------------- topics
def _resolve_topic(name: str, topics: dict, path: str) -> TopicSummary:
    cand = [name] + ([f"/{name}"] if not name.startswith("/") else [])
    for c in cand:
        if c in topics:
            return topics[c]
    usable = [t.name for t in topics.values() if t.msgtype in POSE_TYPES]
    listing = ", ".join(f"{t.name} ({_short(t.msgtype)})" for t in topics.values())
    raise DataError(f"{path}: no topic {name!r} in the bag{did_you_mean(name, list(topics))}; "
                    f"pose topics: {', '.join(usable) or '(none)'}; all topics: "
                    f"{listing or '(none)'}; or give a tf chain '/tf:PARENT->CHILD'")


def _topic_stream(reader, topic: TopicSummary, spec: BagSpec, path: str) -> BagStream:
    if topic.msgtype not in POSE_TYPES:
        hint = (" (a tf topic: give a chain '/tf:PARENT->CHILD')"
                if topic.msgtype in TF_TYPES else "")
        raise DataError(f"{path}: topic {topic.name!r} has type {_short(topic.msgtype)}"
                        f"{hint}; supported: {', '.join(_short(t) for t in POSE_TYPES)}")
    attrs = POSE_TYPES[topic.msgtype]
    stamps, mats, frames, children = [], [], set(), set()
    for _conn, msg in _messages(reader, [topic.name]):
        obj = msg
        for a in attrs:
            obj = getattr(obj, a)
        stamps.append(_ns(msg.header.stamp))
        mats.append(_pose_row(obj))
        frames.add(_frame(msg.header.frame_id))
        children.add(_frame(getattr(msg, "child_frame_id", "")))
    if not stamps:
        raise DataError(f"{path}: topic {topic.name!r} has no messages")
    for what, vals in (("header.frame_id", frames), ("child_frame_id", children)):
        if len(vals) > 1:
            raise DataError(f"{path}: topic {topic.name!r} mixes {what} values "
                            f"{sorted(vals)}; one stream needs one frame")
    ns = np.array(stamps, dtype=np.int64)
    t = stamp_seconds(ns // 1_000_000_000, ns % 1_000_000_000)
    s = stream_from_arrays(t, _matrices(mats), source=f"{path}", name=spec.text)
    parent, child = frames.pop(), children.pop()
    s = replace(s, format=FORMAT, detection=f"topic {topic.name} ({_short(topic.msgtype)}), "
                f"poses in frame {parent!r}" + (f" of {child!r}" if child else ""))
    return BagStream(s, parent, child, spec)


# ------------------------------------------------------------------------- public API
def read_bag(path, spec_a: str, spec_b: str) -> BagStreams:
    """Both streams of a bag, each with its frames (see the module doc for the specs).
    The bag is read once."""
    specs = [parse_spec(spec_a), parse_spec(spec_b)]
    reader = _open(path)
    try:
        topics = _topics(reader)
        resolved = {sp.text: _resolve_topic(sp.topic, topics, str(path))
                    for sp in specs if sp.kind == "topic"}
        edges = _load_tf(reader, topics) if any(sp.kind == "tf" for sp in specs) else {}
        out = [(_tf_stream(edges, sp, str(path)) if sp.kind == "tf" else
                _topic_stream(reader, resolved[sp.text], sp, str(path))) for sp in specs]
    finally:
        reader.close()
    return BagStreams(str(path), out[0], out[1])


def read_bag_streams(path, spec_a: str, spec_b: str) -> tuple[PoseStreamData, PoseStreamData]:
    """``(stream a, stream b)`` from a bag: each ``T_world_sensor`` is the spec's
    ``T_parent_child`` at the header stamps."""
    r = read_bag(path, spec_a, spec_b)
    return r.a.stream, r.b.stream


def read_bag_stream(path, spec: str) -> BagStream:
    """One stream of a bag (with its frames)."""
    sp = parse_spec(spec)
    reader = _open(path)
    try:
        topics = _topics(reader)
        if sp.kind == "tf":
            return _tf_stream(_load_tf(reader, topics), sp, str(path))
        return _topic_stream(reader, _resolve_topic(sp.topic, topics, str(path)), sp,
                             str(path))
    finally:
        reader.close()


def describe_bag(path) -> BagSummary:
    """Topics (type, message count) and tf edges (static or moving, stamps) of a bag."""
    reader = _open(path)
    try:
        topics = _topics(reader)
        edges = _load_tf(reader, topics)
        kind = _kind(reader, Path(path))
        duration = reader.duration / 1e9 if reader.message_count else 0.0
        count = int(reader.message_count)
    finally:
        reader.close()
    summ = []
    for child in sorted(edges, key=lambda c: (edges[c].parent, c)):
        e = edges[child]
        sec = e.stamps_ns // 1_000_000_000
        t = stamp_seconds(sec, e.stamps_ns % 1_000_000_000)
        summ.append(EdgeSummary(e.parent, e.child, e.static, int(t.size), float(t[0]),
                                float(t[-1])))
    return BagSummary(str(path), kind, tuple(sorted(topics.values(), key=lambda t: t.name)),
                      tuple(summ), float(duration), count)


def list_bag(path) -> str:
    """A text listing of a bag: topics with types and counts, tf edges, tf trees."""
    return describe_bag(path).format()


# ------------------------------------------------------------------ frames for exports
def spec_frames(path, spec: str) -> tuple[str, str]:
    """``(parent, child)`` of a spec without reading the stream: a tf spec's two frames; a
    topic's ``header.frame_id`` and ``child_frame_id`` of its first message (``""`` for a
    PoseStamped / PoseWithCovarianceStamped topic, which names no child)."""
    sp = parse_spec(spec)
    if sp.kind == "tf":
        return sp.parent, sp.child
    reader = _open(path)
    try:
        topic = _resolve_topic(sp.topic, _topics(reader), str(path))
        if topic.msgtype not in POSE_TYPES:
            raise DataError(f"{path}: topic {topic.name!r} has type {_short(topic.msgtype)}; "
                            f"supported: {', '.join(_short(t) for t in POSE_TYPES)}")
        for _conn, msg in _messages(reader, [topic.name]):
            return _frame(msg.header.frame_id), _frame(getattr(msg, "child_frame_id", ""))
    finally:
        reader.close()
    raise DataError(f"{path}: topic {sp.topic!r} has no messages")


def export_frames(bag: BagStreams | None = None, *, invert_a: bool = False,
                  invert_b: bool = False, eye: str | None = None, frame_a: str | None = None,
                  frame_b: str | None = None, name: str = "simcalib",
                  path=None, spec_a: str | None = None, spec_b: str | None = None):
    """The :class:`simcalib.ros.exports.ExportFrames` of a calibration from a bag's streams:
    from ``bag`` (a :func:`read_bag` result) or from ``path`` + ``spec_a`` / ``spec_b``
    (:func:`spec_frames`: no stream is read again).

    Stream a's sensor frame (the ``a`` of ``X = T_a_b``) is its spec's CHILD, or its PARENT
    when the calibration read stream a inverted (``invert_a``, from the conventions report);
    the same for b. The other end of spec a is the robot frame easy_handeye2 also needs
    (the base when the eye is in hand, the effector when it is on the base), the other end
    of spec b the marker frame. ``frame_a`` / ``frame_b`` override (required for a
    PoseStamped topic, which names no child frame)."""
    from simcalib.errors import ConfigError
    from simcalib.ros.exports import EYES, ExportFrames
    if eye is not None and eye not in EYES:
        raise ConfigError(key="eye", value=eye, allowed=" or ".join(EYES))
    if bag is not None:
        pairs = [(bag.a.parent, bag.a.child, bag.a.spec.text),
                 (bag.b.parent, bag.b.child, bag.b.spec.text)]
    elif path is not None and spec_a is not None and spec_b is not None:
        pairs = [(*spec_frames(path, sp), sp) for sp in (spec_a, spec_b)]
    else:
        raise TypeError("export_frames needs bag= or path=, spec_a=, spec_b=")
    ends = []
    for (parent, child, text), inv, key, override in ((pairs[0], invert_a, "frame_a", frame_a),
                                                      (pairs[1], invert_b, "frame_b", frame_b)):
        sensor, world = (parent, child) if inv else (child, parent)
        sensor = override or sensor
        if not sensor:
            raise ConfigError(key=key, value=override, allowed=(
                f"the frame name of {text!r} (a PoseStamped topic names no child "
                "frame): give " + key + "=NAME"))
        ends.append((sensor, world or None))
    return ExportFrames(ends[0][0], ends[1][0], eye=eye, robot_frame=ends[0][1],
                        marker_frame=ends[1][1], name=name)
