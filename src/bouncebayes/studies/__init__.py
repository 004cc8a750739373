"""Studies at scale: independent tasks through dask.distributed (serially, on a local cluster of
processes or on a remote one, with identical results), simulation-based calibration, and batches
of runs from a manifest."""

from ._batch import batch_run as batch_run
from ._batch import batch_tasks as batch_tasks
from ._batch import read_manifest as read_manifest
from ._batch import run_batch as run_batch
from ._crossval import SCENARIOS as SCENARIOS
from ._crossval import discrepancy_campaign as discrepancy_campaign
from ._crossval import kfold_coverage as kfold_coverage
from ._crossval import scenario_campaign as scenario_campaign
from ._sbc import SBC_DEFAULTS as SBC_DEFAULTS
from ._sbc import rank_test as rank_test
from ._sbc import run_sbc as run_sbc
from ._sbc import sbc_campaign as sbc_campaign
from ._sbc import sbc_experiment as sbc_experiment
from ._tasks import LOCAL as LOCAL
from ._tasks import SERIAL as SERIAL
from ._tasks import Outcome as Outcome
from ._tasks import Task as Task
from ._tasks import run_tasks as run_tasks
from ._tasks import task_seed as task_seed
from ._tasks import worker_environment as worker_environment

__all__ = ["LOCAL", "SBC_DEFAULTS", "SCENARIOS", "SERIAL", "Outcome", "Task", "batch_run",
           "batch_tasks", "discrepancy_campaign", "kfold_coverage", "rank_test", "read_manifest", "run_batch", "run_sbc", "run_tasks", "sbc_campaign",
           "sbc_experiment", "scenario_campaign", "task_seed", "worker_environment"]
