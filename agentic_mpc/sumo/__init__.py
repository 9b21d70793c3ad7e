"""The SUMO co-simulation: SUMO drives the traffic, our controller and bicycle model drive the ego.

- :mod:`~agentic_mpc.sumo.bridge`: the only module that imports libsumo (conventions converted there);
- :mod:`~agentic_mpc.sumo.network`: lane geometry of a net as the controller's ``LanePath`` s;
- :mod:`~agentic_mpc.sumo.observations`: the typed snapshot of one step (``Observation.to_json()``);
- :mod:`~agentic_mpc.sumo.surroundings`: observation -> the controller's ``Surroundings``;
- :mod:`~agentic_mpc.sumo.cosimulation`: the loop (:class:`CoSimulation`) and its config;
- :mod:`~agentic_mpc.sumo.scenarios`: ready-made configs for the paper's scenarios and the traffic runs.

libsumo runs one simulation per process: run batches in several processes.
"""

from agentic_mpc.sumo.bridge import SumoAlreadyRunningError, SumoBridge, SumoError
from agentic_mpc.sumo.cosimulation import (
    CoSimConfig,
    CoSimulation,
    CoSimulationError,
    EgoStart,
    RunSummary,
    StaticObstacle,
    StepRecord,
    VehicleSpawn,
)
from agentic_mpc.sumo.network import NetworkError, Road, RoadNetwork
from agentic_mpc.sumo.observations import (
    CollisionObservation,
    EgoObservation,
    EmergencyVehicleObservation,
    Observation,
    ObstacleObservation,
    VehicleObservation,
)
from agentic_mpc.sumo.surroundings import SurroundingsBuilder, SurroundingsConfig

__all__ = [
    "CoSimConfig",
    "CoSimulation",
    "CoSimulationError",
    "CollisionObservation",
    "EgoObservation",
    "EgoStart",
    "EmergencyVehicleObservation",
    "NetworkError",
    "Observation",
    "ObstacleObservation",
    "Road",
    "RoadNetwork",
    "RunSummary",
    "StaticObstacle",
    "StepRecord",
    "SumoAlreadyRunningError",
    "SumoBridge",
    "SumoError",
    "SurroundingsBuilder",
    "SurroundingsConfig",
    "VehicleObservation",
    "VehicleSpawn",
]
