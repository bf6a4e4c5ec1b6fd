"""simcalib.ros.bag: bags written with rosbags' own writers (ROS 1, ROS 2 sqlite3,
ROS 2 MCAP) from a simulated hand-eye rig read back to the truth (poses to 1e-9, header
stamps exact, never the record time), plus the errors and the listing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")

from rosbags.rosbag1 import Writer as Writer1  # noqa: E402
from rosbags.rosbag2 import StoragePlugin, Writer as Writer2  # noqa: E402
from rosbags.typesys import Stores, get_types_from_msg, get_typestore  # noqa: E402

from simcalib.errors import DataError  # noqa: E402
from simcalib.geometry import (invert_transform, matrix_from_rotvec,  # noqa: E402
                               quat_from_matrix, random_rotation_matrices,
                               transform_from_rotation_translation)
from simcalib.ros.bag import (describe_bag, list_bag, parse_spec,  # noqa: E402
                                       read_bag, read_bag_stream, read_bag_streams)

STORAGES = ["ros1", "sqlite3", "mcap"]
TOL = 1e-9
REAL = Path("/work/shared/data/real/rwhecalib_kuka_1")


# ------------------------------------------------------------------- writing bags
def _typestore(kind: str):
    if kind == "ros1":
        ts = get_typestore(Stores.ROS1_NOETIC)    # ships no tf2_msgs: register TFMessage
        ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms",
                                       "tf2_msgs/msg/TFMessage"))
        return ts
    return get_typestore(Stores.ROS2_HUMBLE)


class BagBuilder:
    """Collects messages (header stamp, record time), then writes them with rosbags'
    writer for ``kind`` in record-time order."""

    def __init__(self, kind: str):
        self.kind = kind
        self.ts = _typestore(kind)
        self.msgs: list[tuple[int, str, str, object]] = []   # (record ns, topic, type, msg)

    # message construction
    def _t(self, name):
        return self.ts.types[name]

    def header(self, ns: int, frame: str):
        stamp = self._t("builtin_interfaces/msg/Time")(sec=ns // 10**9, nanosec=ns % 10**9)
        H = self._t("std_msgs/msg/Header")
        if self.kind == "ros1":
            return H(seq=0, stamp=stamp, frame_id=frame)
        return H(stamp=stamp, frame_id=frame)

    def transform(self, T):
        q = quat_from_matrix(T[:3, :3])
        return self._t("geometry_msgs/msg/Transform")(
            translation=self._t("geometry_msgs/msg/Vector3")(*map(float, T[:3, 3])),
            rotation=self._t("geometry_msgs/msg/Quaternion")(*map(float, q)))

    def pose(self, T):
        q = quat_from_matrix(T[:3, :3])
        return self._t("geometry_msgs/msg/Pose")(
            position=self._t("geometry_msgs/msg/Point")(*map(float, T[:3, 3])),
            orientation=self._t("geometry_msgs/msg/Quaternion")(*map(float, q)))

    def tstamped(self, ns, parent, child, T):
        return self._t("geometry_msgs/msg/TransformStamped")(
            header=self.header(ns, parent), child_frame_id=child, transform=self.transform(T))

    # adding
    def add(self, record_ns: int, topic: str, msgtype: str, msg):
        self.msgs.append((int(record_ns), topic, msgtype, msg))

    def tf(self, topic, record_ns, items):
        """items: [(stamp ns, parent, child, T)] in one TFMessage."""
        msg = self._t("tf2_msgs/msg/TFMessage")(
            transforms=[self.tstamped(ns, p, c, T) for ns, p, c, T in items])
        self.add(record_ns, topic, "tf2_msgs/msg/TFMessage", msg)

    def pose_topic(self, topic, msgtype, stamps_ns, frame, child, Ts, lag_ns=250_000_000):
        for ns, T in zip(stamps_ns, Ts):
            h = self.header(int(ns), frame)
            if msgtype == "geometry_msgs/msg/PoseStamped":
                msg = self._t(msgtype)(header=h, pose=self.pose(T))
            elif msgtype == "geometry_msgs/msg/PoseWithCovarianceStamped":
                msg = self._t(msgtype)(header=h, pose=self._pwc(T))
            elif msgtype == "geometry_msgs/msg/TransformStamped":
                msg = self.tstamped(int(ns), frame, child, T)
            elif msgtype == "nav_msgs/msg/Odometry":
                tw = self._t("geometry_msgs/msg/Twist")(
                    linear=self._t("geometry_msgs/msg/Vector3")(0.0, 0.0, 0.0),
                    angular=self._t("geometry_msgs/msg/Vector3")(0.0, 0.0, 0.0))
                msg = self._t(msgtype)(header=h, child_frame_id=child, pose=self._pwc(T),
                                       twist=self._t("geometry_msgs/msg/TwistWithCovariance")(
                                           twist=tw, covariance=np.zeros(36)))
            else:
                raise AssertionError(msgtype)
            self.add(int(ns) + lag_ns, topic, msgtype, msg)

    def _pwc(self, T):
        return self._t("geometry_msgs/msg/PoseWithCovariance")(pose=self.pose(T),
                                                               covariance=np.zeros(36))

    def string_topic(self, topic, record_ns, text):
        self.add(record_ns, topic, "std_msgs/msg/String", self._t("std_msgs/msg/String")(text))

    def write(self, path: Path) -> Path:
        self.msgs.sort(key=lambda m: m[0])
        if self.kind == "ros1":
            path = path.with_suffix(".bag")
            writer = Writer1(path)
            ser = self.ts.serialize_ros1
        else:
            plugin = StoragePlugin.MCAP if self.kind == "mcap" else StoragePlugin.SQLITE3
            writer = Writer2(path, version=9, storage_plugin=plugin)
            ser = self.ts.serialize_cdr
        with writer:
            conns = {}
            for rec, topic, msgtype, msg in self.msgs:
                if topic not in conns:
                    conns[topic] = writer.add_connection(topic, msgtype, typestore=self.ts)
                writer.write(conns[topic], rec, ser(msg, msgtype))
        return path


# ------------------------------------------------------------------ the simulated rig
def _random_T(rng, n=None, scale=0.5):
    shape = () if n is None else (n,)
    return transform_from_rotation_translation(random_rotation_matrices(rng, shape),
                                               rng.uniform(-scale, scale, shape + (3,)))


def _seconds(ns):
    return np.array([int(v) // 10**9 + (int(v) % 10**9) / 1e9 for v in ns])


class Rig:
    """T_base_hand (two moving links), X = T_tool0_cam, a fixed board; tf tree
    world -> base_link (static) -> link1 -> tool0 and camera_link -> board (moving),
    camera_link -> camera_optical (static)."""

    def __init__(self, seed: int, n: int = 30):
        rng = np.random.default_rng(seed)
        t0 = 1_700_000_000 * 10**9 + 123_456_789
        self.hand_ns = t0 + np.arange(n, dtype=np.int64) * 100_000_000 + rng.integers(
            0, 1000, n)
        self.cam_ns = self.hand_ns + 3_000_017
        self.S = _random_T(rng)                       # T_world_base_link (static)
        self.O = _random_T(rng, scale=0.05)           # T_camera_link_camera_optical
        self.X = _random_T(rng, scale=0.2)            # T_tool0_camera_link
        self.T_base_target = _random_T(rng, scale=1.0)
        self.T_base_link1 = _random_T(rng, n)
        self.T_base_hand = _random_T(rng, n)
        self.T_link1_tool0 = invert_transform(self.T_base_link1) @ self.T_base_hand
        self.T_target_cam = invert_transform(self.T_base_target) @ self.T_base_hand @ self.X

    def builder(self, kind: str, topics: bool = False) -> BagBuilder:
        b = BagBuilder(kind)
        lag = 250_000_000
        b.tf("/tf_static", 0, [(int(self.hand_ns[0]), "world", "base_link", self.S),
                               (int(self.hand_ns[0]), "camera_link", "camera_optical",
                                self.O)])
        for k, ns in enumerate(self.hand_ns):
            b.tf("/tf", int(ns) + lag, [(int(ns), "base_link", "link1", self.T_base_link1[k]),
                                        (int(ns), "link1", "tool0", self.T_link1_tool0[k])])
        for k, ns in enumerate(self.cam_ns):
            b.tf("/tf", int(ns) + lag + 7, [(int(ns), "/camera_link", "board",
                                             invert_transform(self.T_target_cam[k]))])
        if topics:
            b.pose_topic("/hand_pose", "geometry_msgs/msg/PoseStamped", self.hand_ns,
                         "base_link", "", self.T_base_hand)
            b.pose_topic("/cam_odom", "nav_msgs/msg/Odometry", self.cam_ns, "board",
                         "camera_link", self.T_target_cam)
            b.pose_topic("/cam_tf", "geometry_msgs/msg/TransformStamped", self.cam_ns,
                         "board", "camera_link", self.T_target_cam)
            b.pose_topic("/cam_pwc", "geometry_msgs/msg/PoseWithCovarianceStamped",
                         self.cam_ns, "board", "", self.T_target_cam)
            b.string_topic("/chatter", int(self.hand_ns[0]), "hello")
        return b


def _close(T, T_true, tol=TOL):
    assert T.shape == T_true.shape
    err = np.abs(np.asarray(T) - T_true).max()
    assert err < tol, f"max abs error {err:.3g}"


@pytest.fixture(scope="module")
def rig():
    return Rig(seed=7)


@pytest.fixture(scope="module", params=STORAGES)
def tf_bag(request, rig, tmp_path_factory):
    return rig.builder(request.param).write(tmp_path_factory.mktemp("tf") / "rig")


@pytest.fixture(scope="module", params=STORAGES)
def topic_bag(request, rig, tmp_path_factory):
    return rig.builder(request.param, topics=True).write(
        tmp_path_factory.mktemp("topics") / "rig")


# --------------------------------------------------------------------------- round trips
def test_tf_chains_round_trip_to_the_truth(tf_bag, rig):
    a, b = read_bag_streams(tf_bag, "/tf:world->tool0", "/tf:board->camera_optical")
    assert a.format == "rosbag" and a.name == "/tf:world->tool0"
    np.testing.assert_array_equal(a.timestamps_s, _seconds(rig.hand_ns))   # header, exact
    _close(a.T_world_sensor, rig.S @ rig.T_base_hand)
    np.testing.assert_array_equal(b.timestamps_s, _seconds(rig.cam_ns))
    _close(b.T_world_sensor, rig.T_target_cam @ rig.O)
    assert "tf_edges_interpolated" not in a.repairs      # both moving links share stamps


def test_tf_chain_either_direction_and_frames(tf_bag, rig):
    r = read_bag(tf_bag, "tf:camera_optical->board", "/tf:/tool0->/base_link")
    _close(r.a.stream.T_world_sensor,
           invert_transform(rig.O) @ invert_transform(rig.T_target_cam))
    _close(r.b.stream.T_world_sensor, invert_transform(rig.T_base_hand))
    assert (r.a.parent, r.a.child) == ("camera_optical", "board")
    assert (r.b.parent, r.b.child) == ("tool0", "base_link")
    assert r.b.moving_edges == ("link1->tool0", "base_link->link1")   # composition order
    assert r.b.interpolated == 0


def test_pose_topics_round_trip(topic_bag, rig):
    hand = read_bag_stream(topic_bag, "/hand_pose")
    _close(hand.stream.T_world_sensor, rig.T_base_hand)
    np.testing.assert_array_equal(hand.stream.timestamps_s, _seconds(rig.hand_ns))
    assert (hand.parent, hand.child) == ("base_link", "")
    for topic, child in (("/cam_odom", "camera_link"), ("/cam_tf", "camera_link"),
                         ("cam_pwc", "")):
        s = read_bag_stream(topic_bag, topic)
        _close(s.stream.T_world_sensor, rig.T_target_cam)
        np.testing.assert_array_equal(s.stream.timestamps_s, _seconds(rig.cam_ns))
        assert (s.parent, s.child) == ("board", child)


def test_topic_and_tf_specs_mixed(topic_bag, rig):
    a, b = read_bag_streams(topic_bag, "/tf:base_link->tool0", "/cam_odom")
    _close(a.T_world_sensor, rig.T_base_hand)
    _close(b.T_world_sensor, rig.T_target_cam)


def test_moving_edges_with_different_stamps_are_interpolated_like_tf2(tmp_path):
    """Edge 1 (base->link1) translates linearly and turns about a fixed axis at a constant
    rate, so tf2's lerp/slerp is exact at any stamp; edge 2 (link1->tool0) has other
    stamps. The chain's stamps: the union inside the common span."""
    rng = np.random.default_rng(3)
    axis = rng.standard_normal(3)
    axis /= np.linalg.norm(axis)
    v, w, p0 = rng.uniform(-0.3, 0.3, 3), 0.7, rng.uniform(-1, 1, 3)
    t0 = 50 * 10**9

    def edge1(ns):
        tau = (np.asarray(ns, dtype=np.int64) - t0).astype(float) / 1e9
        return transform_from_rotation_translation(
            matrix_from_rotvec(np.outer(tau * w, axis)), p0 + np.outer(tau, v))

    ns1 = t0 + np.arange(0, 21) * 100_000_000                 # 0 .. 2.0 s
    ns2 = t0 + 50_000_000 + np.arange(0, 15) * 130_000_000    # 0.05 .. 1.87 s
    E2 = _random_T(rng, ns2.size)
    b = BagBuilder("mcap")
    for k, ns in enumerate(ns1):
        b.tf("/tf", int(ns), [(int(ns), "base", "link1", edge1([ns])[0])])
    for k, ns in enumerate(ns2):
        b.tf("/tf", int(ns) + 1, [(int(ns), "link1", "tool0", E2[k])])
    path = b.write(tmp_path / "interp")
    r = read_bag_stream(path, "/tf:base->tool0")
    union = np.union1d(ns1, ns2)
    union = union[(union >= ns2[0]) & (union <= ns2[-1])]
    np.testing.assert_array_equal(r.stream.timestamps_s, _seconds(union))
    # at ns2 stamps edge 2 is exact; edge 1 interpolated (exact by construction)
    at2 = np.isin(union, ns2)
    _close(r.stream.T_world_sensor[at2], edge1(union[at2]) @ E2)
    assert r.interpolated == int((~np.isin(union, ns1) | ~np.isin(union, ns2)).sum())
    assert r.stream.repairs["tf_edges_interpolated"] == r.interpolated


def test_interpolation_of_a_single_edge_matches_slerp(tmp_path):
    """A chain through one moving edge is read at that edge's own stamps only (no
    interpolation); through two edges the interpolated poses lie on the slerp."""
    rng = np.random.default_rng(11)
    R0, R1 = random_rotation_matrices(rng, 2)
    T0 = transform_from_rotation_translation(R0, [0.0, 0.0, 0.0])
    T1 = transform_from_rotation_translation(R1, [1.0, 2.0, 3.0])
    b = BagBuilder("sqlite3")
    b.tf("/tf", 10, [(10**9, "a", "b", T0)])
    b.tf("/tf", 11, [(3 * 10**9, "a", "b", T1)])
    for k, ns in enumerate((10**9, 2 * 10**9, 3 * 10**9)):      # edge b->c at 1, 2, 3 s
        b.tf("/tf", 12 + k, [(ns, "b", "c", np.eye(4))])
    path = b.write(tmp_path / "slerp")
    r = read_bag_stream(path, "/tf:a->c")
    mid = r.stream.T_world_sensor[1]
    from simcalib.geometry import rotvec_from_matrix
    half = R0 @ matrix_from_rotvec(0.5 * rotvec_from_matrix(R0.T @ R1))
    _close(mid[:3, :3], half)
    _close(mid[:3, 3], np.array([0.5, 1.0, 1.5]))
    assert r.interpolated == 1


# ----------------------------------------------------------------------------- listing
def test_list_bag_names_topics_types_counts_and_edges(topic_bag, rig):
    text = list_bag(topic_bag)
    n = len(rig.hand_ns)
    line = next(ln for ln in text.splitlines() if ln.strip().startswith("/hand_pose"))
    assert line.split() == ["/hand_pose", "geometry_msgs/PoseStamped", str(n), "<-",
                            "usable", "as", "a", "stream", "spec"]
    summ = describe_bag(topic_bag)
    topics = {t.name: (t.msgtype, t.count) for t in summ.topics}
    assert topics["/hand_pose"] == ("geometry_msgs/msg/PoseStamped", n)
    assert topics["/cam_odom"] == ("nav_msgs/msg/Odometry", n)
    assert topics["/tf"] == ("tf2_msgs/msg/TFMessage", 2 * n)
    assert topics["/tf_static"] == ("tf2_msgs/msg/TFMessage", 1)
    edges = {(e.parent, e.child): (e.static, e.count) for e in summ.edges}
    assert edges == {("world", "base_link"): (True, 1), ("base_link", "link1"): (False, n),
                     ("link1", "tool0"): (False, n), ("camera_link", "board"): (False, n),
                     ("camera_link", "camera_optical"): (True, 1)}
    for needle in ("world -> base_link  (static)", "camera_link -> board  (moving, 30",
                   "nav_msgs/Odometry", "std_msgs/String", "root world:", "root camera_link:"):
        assert needle in text, needle
    assert summ.kind == {".bag": "ROS 1"}.get(Path(topic_bag).suffix, summ.kind)
    assert summ.kind in ("ROS 1", "ROS 2 sqlite3", "ROS 2 mcap")


def test_describe_bag_tells_the_storage(tmp_path, rig):
    for kind, want in (("ros1", "ROS 1"), ("sqlite3", "ROS 2 sqlite3"),
                       ("mcap", "ROS 2 mcap")):
        p = BagBuilder(kind)
        p.tf("/tf", 5, [(10**9, "a", "b", np.eye(4))])
        assert describe_bag(p.write(tmp_path / kind)).kind == want


# ------------------------------------------------------------------------------ errors
@pytest.fixture(scope="module")
def mcap_topics(rig, tmp_path_factory):
    return rig.builder("mcap", topics=True).write(tmp_path_factory.mktemp("err") / "rig")


@pytest.mark.parametrize("spec_b, needles", [
    ("/no_such", ["no topic '/no_such'", "/hand_pose", "/cam_odom", "/chatter"]),
    ("/hand_pos", ["did you mean '/hand_pose'"]),
    ("/chatter", ["std_msgs/String", "supported:", "nav_msgs/Odometry"]),
    ("/tf", ["tf2_msgs/TFMessage", "/tf:PARENT->CHILD"]),
    ("/tf:world->camra_link", ["'camra_link'", "did you mean 'camera_link'", "frames:",
                               "tool0"]),
    ("/tf:world->board", ["not connected", "rooted at 'world'", "rooted at 'camera_link'"]),
    ("/tf:world->base_link", ["static", "world->base_link", "needs a moving edge"]),
    ("/tf:tool0", ["'/tf:PARENT->CHILD'", "received '/tf:tool0'"]),
    ("/tf:tool0->tool0", ["same frame twice"]),
    ("", ["received ''"]),
])
def test_bad_specs_say_what_exists(mcap_topics, spec_b, needles):
    with pytest.raises(DataError) as exc:
        read_bag_streams(mcap_topics, "/tf:base_link->tool0", spec_b)
    for n in needles:
        assert n in str(exc.value), (n, str(exc.value))


def test_not_a_bag_and_missing_path(tmp_path):
    with pytest.raises(DataError, match="does not exist"):
        list_bag(tmp_path / "nothing.bag")
    txt = tmp_path / "poses.bag"
    txt.write_text("0 0 0 0 0 0 0 1\n")
    with pytest.raises(DataError, match="not a readable bag.*ROS 1 .bag file"):
        read_bag_streams(txt, "/tf:a->b", "/tf:c->d")
    d = tmp_path / "dir"
    d.mkdir()
    with pytest.raises(DataError, match="not a readable bag.*metadata.yaml"):
        list_bag(d)


def test_a_frame_with_two_parents_is_an_error(tmp_path):
    b = BagBuilder("ros1")
    b.tf("/tf", 1, [(10**9, "a", "c", np.eye(4))])
    b.tf("/tf", 2, [(2 * 10**9, "b", "c", np.eye(4))])
    with pytest.raises(DataError, match="'c' has two parents.*'a' and 'b'"):
        read_bag_stream(b.write(tmp_path / "two"), "/tf:a->c")


def test_a_topic_mixing_frames_is_an_error(tmp_path, rig):
    b = BagBuilder("sqlite3")
    b.pose_topic("/p", "geometry_msgs/msg/PoseStamped", rig.hand_ns[:3], "map", "",
                 rig.T_base_hand[:3])
    b.pose_topic("/p", "geometry_msgs/msg/PoseStamped", rig.hand_ns[3:6], "odom", "",
                 rig.T_base_hand[3:6])
    with pytest.raises(DataError, match=r"mixes header.frame_id values \['map', 'odom'\]"):
        read_bag_stream(b.write(tmp_path / "mixed"), "/p")


def test_parse_spec():
    s = parse_spec(" /tf:/base_link->tool0 ")
    assert (s.kind, s.parent, s.child) == ("tf", "base_link", "tool0")
    t = parse_spec("/robot/pose")
    assert (t.kind, t.topic) == ("topic", "/robot/pose")


# ----------------------------------------------------------------- a real recording
@pytest.mark.skipif(not (REAL / "a.txt").is_file() or not (REAL / "b.txt").is_file(),
                    reason="real recording rwhecalib_kuka_1 not present")
@pytest.mark.parametrize("kind", ["ros1", "mcap"])
def test_real_recording_through_a_bag(tmp_path, kind):
    """rwhecalib_kuka_1 (TUM files) -> a bag (a on /tf base->tcp with a static world
    frame, b as PoseStamped) -> read back to the same poses and stamps."""
    from simcalib.importers import read_pose_stream
    a = read_pose_stream(REAL / "a.txt", "tum")
    b = read_pose_stream(REAL / "b.txt", "tum")
    to_ns = lambda t: np.round(np.asarray(t) * 1e9).astype(np.int64) + 10**9  # noqa: E731
    na, nb = to_ns(a.timestamps_s), to_ns(b.timestamps_s)
    bag = BagBuilder(kind)
    bag.tf("/tf_static", 0, [(int(na[0]), "world", "base", np.eye(4))])
    for ns, T in zip(na, a.T_world_sensor):
        bag.tf("/tf", int(ns), [(int(ns), "base", "tcp", T)])
    bag.pose_topic("/camera/pose", "geometry_msgs/msg/PoseStamped", nb, "camera", "",
                   b.T_world_sensor)
    path = bag.write(tmp_path / "kuka")
    ra, rb = read_bag_streams(path, "/tf:world->tcp", "/camera/pose")
    for got, want, ns in ((ra, a, na), (rb, b, nb)):
        assert got.n == want.n
        _close(got.T_world_sensor, want.T_world_sensor)
        np.testing.assert_array_equal(got.timestamps_s, _seconds(ns))
        np.testing.assert_allclose(got.timestamps_s - 1.0, want.timestamps_s, atol=1e-9)


# ------------------------------------------------- end to end: bag -> X -> exports
@pytest.mark.parametrize("eye", ["in_hand", "on_base"])
def test_calibration_from_a_bag_recovers_X_and_exports_it(tmp_path, eye):
    """The frame naming of docs/ros.md: eye in hand, a=/tf:base_link->tool0 and
    b=/tf:camera_link->board (read inverted by the conventions) give X = T_tool0_camera;
    eye on base, a=/tf:tool0->base_link and b=/tf:marker->camera_link give
    X = T_base_link_camera. Both exported to easy_handeye2 and URDF with the right frames."""
    from simcalib.estimation.path import calibrate_streams
    from simcalib.ros.exports import parse_easy_handeye2, parse_urdf_joint, write_exports
    from simcalib.ros.bag import export_frames
    rig = Rig(seed=5, n=40)
    rng = np.random.default_rng(17)
    fixed = _random_T(rng, scale=0.3)        # in hand: T_tool0_cam; on base: T_base_cam
    other = _random_T(rng, scale=0.3)        # in hand: T_base_board; on base: T_tool0_marker
    b = BagBuilder("mcap")
    for k, ns in enumerate(rig.hand_ns):
        T_bt = rig.T_base_hand[k]
        if eye == "in_hand":
            track = invert_transform(T_bt @ fixed) @ other         # T_cam_board
            edge = (int(ns), "camera_link", "board", track)
        else:
            track = invert_transform(fixed) @ T_bt @ other         # T_cam_marker
            edge = (int(ns), "camera_link", "marker", track)
        b.tf("/tf", int(ns), [(int(ns), "base_link", "link1", rig.T_base_link1[k]),
                              (int(ns), "link1", "tool0", rig.T_link1_tool0[k]), edge])
    path = b.write(tmp_path / eye)
    specs = (("/tf:base_link->tool0", "/tf:camera_link->board") if eye == "in_hand" else
             ("/tf:tool0->base_link", "/tf:marker->camera_link"))
    bag = read_bag(path, *specs)
    r = calibrate_streams(bag.a.stream, bag.b.stream, time_offset=0.0)
    _close(r.X, fixed, tol=1e-8)
    frames = export_frames(bag, invert_a=r.conventions.invert_a,
                           invert_b=r.conventions.invert_b, eye=eye)
    want = (("tool0", "camera_link", "base_link", "board") if eye == "in_hand" else
            ("base_link", "camera_link", "tool0", "marker"))
    assert (frames.frame_a, frames.frame_b, frames.robot_frame, frames.marker_frame) == want
    paths = write_exports(tmp_path / "out", r.X, ["urdf", "easy_handeye2"], frames)
    eh = parse_easy_handeye2(paths["easy_handeye2"].read_text())
    params = eh.details["parameters"]
    assert params["calibration_type"] == ("eye_in_hand" if eye == "in_hand" else "eye_on_base")
    assert (params["robot_base_frame"], params["robot_effector_frame"]) == ("base_link", "tool0")
    assert (params["tracking_base_frame"], params["tracking_marker_frame"]) == (want[1], want[3])
    _close(eh.X, fixed, tol=1e-8)
    u = parse_urdf_joint(paths["urdf"].read_text())
    assert (u.parent, u.child) == want[:2]
    _close(u.X, fixed, tol=1e-8)


def test_export_frames_needs_a_name_for_pose_stamped(topic_bag):
    from simcalib.errors import ConfigError
    from simcalib.ros.bag import export_frames, spec_frames
    bag = read_bag(topic_bag, "/hand_pose", "/cam_odom")
    with pytest.raises(ConfigError, match="frame_a.*PoseStamped topic names no child"):
        export_frames(bag)
    f = export_frames(bag, frame_a="tool0", invert_b=True)
    assert (f.frame_a, f.frame_b, f.robot_frame, f.marker_frame) == (
        "tool0", "board", "base_link", "camera_link")
    with pytest.raises(ConfigError, match="eye must be in_hand or on_base"):
        export_frames(bag, frame_a="tool0", eye="hand")
    g = export_frames(path=topic_bag, spec_a="/hand_pose", spec_b="/cam_odom",
                      frame_a="tool0", invert_b=True)          # from the specs, cheaply
    assert g == f
    assert spec_frames(topic_bag, "/cam_tf") == ("board", "camera_link")
    assert spec_frames(topic_bag, "/tf:a->b") == ("a", "b")
    with pytest.raises(DataError, match="std_msgs/String"):
        spec_frames(topic_bag, "/chatter")
