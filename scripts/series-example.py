"""Write a small example campaign as a user has it: a record table without motion columns, the
raw IMU series and the LOS series (the README's "Run on your own data" example).

    .venv/bin/python scripts/series-example.py example

writes ``example/records.csv`` (36 records of 10 min at 58 and 85 m, with a reference
instrument, no motion columns, no truth), ``example/imu.csv`` (roll, pitch, yaw at 5 Hz with
noise and gaps) and ``example/los.parquet`` (the ZephIR-like lidar's lines of sight, sorted
by time). The numbers are those of the virtual campaign (physics mode, seed 11), so
``tests/data/user_series_config.yaml`` runs on them; the buoy's lidar head sits 2.5 m above
its rotation centre.
"""

from __future__ import annotations

import argparse
import copy
from pathlib import Path

from flidar_uq.campaign.physics_mode import generate_campaign
from flidar_uq.campaign.scenarios import DEFAULT_SCENARIO
from flidar_uq.data import io
from flidar_uq.data.imu_series import SERIES_MOTION_COLUMNS
from flidar_uq.data.schema import TRUTH_PREFIX


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("outdir", help="directory to write records.csv, imu.csv, los.parquet")
    parser.add_argument("--records", type=int, default=36, help="10-min records (default 36)")
    parser.add_argument("--seed", type=int, default=11, help="seed of the virtual campaign")
    args = parser.parse_args()
    scenario = copy.deepcopy(DEFAULT_SCENARIO)
    scenario.update(name="series_example", n_records=args.records, heights_m=[58.0, 85.0])
    scenario["imu"]["gap_probability"] = 0.1
    out = generate_campaign(scenario, args.seed, return_imu=True, return_los=True, n_workers=1)
    drop = [c for c in out.records if c in SERIES_MOTION_COLUMNS or c.startswith(TRUTH_PREFIX)]
    outdir = Path(args.outdir)
    io.write_records(out.records.drop(columns=drop), outdir / "records.csv", require_motion=False)
    io.write_imu_series(out.imu, outdir / "imu.csv")
    io.write_los_series(out.los, outdir / "los.parquet")
    print(
        f"{outdir}: records.csv ({len(out.records)} rows), imu.csv ({len(out.imu)} samples), "
        f"los.parquet ({len(out.los)} lines of sight)"
    )


if __name__ == "__main__":
    main()
