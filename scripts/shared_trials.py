"""Prints the lines of a search's trial log whose trial number is below BELOW, to seed a new
search's log with the points it shares with the old one (`braille train --search` takes a logged
trial whose number, recipe and seeds match instead of training it again).

    python3 scripts/shared_trials.py LOG BELOW > NEW_DIR/trials-0-of-1.jsonl

A log written when the recipe's `realism` defaulted to `clean` (raw1350-warmup, 2026-11-25) has
it brought to today's default, `nominal`: a field of the simulated training windows that the
tactile trainer does not read (a search retraining such trials at `nominal` scored them to the
digit), so that the new search recognises the trials."""

import json
import sys

log, below = sys.argv[1], int(sys.argv[2])
for line in open(log):
    t = json.loads(line)
    if t["trial"] >= below:
        continue
    if t["recipe"].get("realism") == "clean":
        t["recipe"]["realism"] = "nominal"
        line = json.dumps(t, separators=(",", ":")) + "\n"
    sys.stdout.write(line)
