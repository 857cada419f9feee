"""``serve(planner)``: a Python planner as a gRPC ``Planner`` service for the benchmark service.

Run a script that ends with ``serve(MyPlanner())`` and submit it with ``vb-submit exec -- python my_planner.py``
(check it first with ``vb-submit validate exec -- python my_planner.py``): the worker starts the script with
``VB_PLANNER_ADDR`` set to the address to serve on, drives episodes over ``PlanEpisode`` and stops the process
afterwards. Needs ``grpcio`` (``pip install 'vertibench[grpc]'``).
"""

from __future__ import annotations

import os
import sys
import traceback

import numpy as np

from . import protocol as pb
from .planner import Maps, Planner, Task, action_tuple, make_observation

#: Where a planner serves when ``VB_PLANNER_ADDR`` is unset.
DEFAULT_ADDR = "127.0.0.1:50061"


def _task(t) -> Task:
    return Task(
        id=t.task_id,
        world_id=t.world_id,
        index=t.index,
        start=np.array([t.start.x, t.start.y]),
        goal=np.array([t.goal.x, t.goal.y]),
        path=np.array([[p.x, p.y] for p in t.global_path]).reshape(-1, 2),
        level=t.elevation_level,
        semantics=t.semantics,
        density=t.obstacle_density,
        scale=t.scale,
    )


def _grid(g, dtype):
    # A copy: believed maps are updated in place.
    data = np.frombuffer(g.data, dtype=np.uint8).copy() if dtype == np.uint8 else np.asarray(g.data, dtype=dtype)
    return data.reshape(g.ny, g.nx)


def _maps(m, believed: bool = False) -> Maps:
    return Maps(
        elevation=_grid(m.elevation, np.float32),
        semantics=_grid(m.semantics, np.uint8),
        obstacles=_grid(m.obstacles, np.uint8),
        friction=_grid(m.friction, np.float32),
        cell=m.elevation.cell,
        believed=believed,
    )


def _update(maps: Maps | None, o) -> None:
    """Pastes an observation's ``MapUpdate`` (what the sensor saw since the last one) into the believed maps."""
    if maps is None or not o.HasField("map_update"):
        return
    u = o.map_update
    maps.update(u.x0, u.y0, _grid(u.elevation, np.float32), _grid(u.obstacles, np.uint8))


def _vehicle(v) -> dict:
    keys = ("name", "scale", "wheelbase", "track", "length", "width", "max_steer", "skid_steer", "nominal_speed",
            "max_speed")
    return {k: getattr(v, k) for k in keys}


def _observation(o):
    s = o.state
    state = (s.time, s.x, s.y, s.z, s.roll, s.pitch, s.yaw, s.vx, s.vy, s.vz, s.wx, s.wy, s.wz, s.speed, s.steering)
    crops = None
    if o.HasField("local"):
        crops = (_grid(o.local.elevation, np.float32), _grid(o.local.semantics, np.uint8),
                 _grid(o.local.obstacles, np.uint8))
    return make_observation(state, crops)


class _Servicer:
    def __init__(self, planner: Planner, version: str):
        self.planner = planner
        self.version = version
        self.maps: Maps | None = None

    def info(self, request, context):
        p = self.planner
        return pb.PlannerInfo(
            name=p.name,
            version=self.version,
            control_rate_hz=float(p.control_rate_hz),
            local_map_size=int(p.crop_size),
            local_map_resolution=float(p.crop_resolution),
        )

    def plan_episode(self, requests, context):
        import grpc

        for msg in requests:
            kind = msg.WhichOneof("msg")
            try:
                if kind == "start":
                    st = msg.start
                    self.maps = _maps(st.maps, st.believed)
                    self.planner.reset(_task(st.task), _vehicle(st.vehicle), self.maps)
                    yield pb.PlannerMessage(ready=True)
                elif kind == "observation":
                    _update(self.maps, msg.observation)
                    s, t, b = action_tuple(self.planner.act(_observation(msg.observation)))
                    yield pb.PlannerMessage(action=pb.Action(steering=s, throttle=t, brake=b))
                else:
                    return
            except Exception:
                # The worker fails the episode with reason planner_crash and keeps this text as its detail.
                context.abort(grpc.StatusCode.INTERNAL, traceback.format_exc(limit=8)[-4000:])


def serve(planner: Planner, address: str | None = None, *, version: str = "", block: bool = True):
    """Serves ``planner`` on ``address`` (default: ``$VB_PLANNER_ADDR``, else ``127.0.0.1:50061``). Episodes run
    one at a time. With ``block=False`` returns the started ``grpc.Server`` (call ``stop(None)`` on it)."""
    from concurrent import futures

    try:
        import grpc
    except ImportError:
        raise ImportError("serve() needs grpcio: pip install 'vertibench[grpc]'") from None

    address = address or os.environ.get("VB_PLANNER_ADDR") or DEFAULT_ADDR
    servicer = _Servicer(planner, version)
    handlers = {
        "PlanEpisode": grpc.stream_stream_rpc_method_handler(
            servicer.plan_episode,
            request_deserializer=pb.WorkerMessage.FromString,
            response_serializer=pb.PlannerMessage.SerializeToString,
        ),
        "Info": grpc.unary_unary_rpc_method_handler(
            servicer.info,
            request_deserializer=pb.InfoRequest.FromString,
            response_serializer=pb.PlannerInfo.SerializeToString,
        ),
    }
    # One episode at a time: a planner object holds one episode's state.
    server = grpc.server(futures.ThreadPoolExecutor(max_workers=2), maximum_concurrent_rpcs=2)
    server.add_generic_rpc_handlers((grpc.method_handlers_generic_handler(pb.PLANNER_SERVICE, handlers),))
    if server.add_insecure_port(address) == 0:
        raise OSError(f"cannot listen on {address}")
    server.start()
    print(f"vertibench planner {planner.name!r} serving on {address}", file=sys.stderr, flush=True)
    if not block:
        return server
    try:
        server.wait_for_termination()
    except KeyboardInterrupt:
        server.stop(grace=None)
    return server
