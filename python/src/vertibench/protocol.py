"""The vertibench gRPC protocol's message classes (package ``vertibench.v1``), built from the ``.proto`` files that
were compiled into the extension when the package was built (no generated files to keep in step).

``protocol.Observation``, ``protocol.PlannerMessage``, ... are ordinary protobuf message classes; the service and
method names are in :data:`PLANNER_SERVICE`.
"""

from __future__ import annotations

try:
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
except ImportError as _e:  # pragma: no cover - depends on what is installed
    raise ImportError(
        "vertibench.protocol and vertibench.serve need protobuf and grpcio: pip install 'vertibench[grpc]'"
    ) from _e

from . import _core

PACKAGE = "vertibench.v1"
PLANNER_SERVICE = f"{PACKAGE}.Planner"
SIM_SERVICE = f"{PACKAGE}.Sim"

_pool = descriptor_pool.DescriptorPool()
for _file in descriptor_pb2.FileDescriptorSet.FromString(_core.PROTO_DESCRIPTOR_SET).file:
    _pool.Add(_file)


def message(name: str):
    """The message class ``vertibench.v1.<name>``."""
    return message_factory.GetMessageClass(_pool.FindMessageTypeByName(f"{PACKAGE}.{name}"))


WorkerMessage = message("WorkerMessage")
PlannerMessage = message("PlannerMessage")
PlannerInfo = message("PlannerInfo")
InfoRequest = message("InfoRequest")
Observation = message("Observation")
Action = message("Action")
EpisodeStart = message("EpisodeStart")
CreateEpisodeRequest = message("CreateEpisodeRequest")
CreateEpisodeResponse = message("CreateEpisodeResponse")
ResetRequest = message("ResetRequest")
StepRequest = message("StepRequest")
StepResponse = message("StepResponse")
CloseEpisodeRequest = message("CloseEpisodeRequest")
CloseEpisodeResponse = message("CloseEpisodeResponse")
GetMapsRequest = message("GetMapsRequest")
WorldMaps = message("WorldMaps")
