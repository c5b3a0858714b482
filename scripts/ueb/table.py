"""The UEB readers' tables from scripts/ueb/tables.sh's JSON: docs/results/REALISM/ueb/ueb.md."""
import json
import pathlib
import sys

out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "docs/results/nominal/ueb")
lines = ["# UEB readers (SIMULATED)", "",
         "Made by `bash scripts/ueb/tables.sh` (test sensor builds, test seed; models/REALISM/ueb/). "
         "The reading times were measured beside other jobs on two cores; the cost against the letters' reader is "
         "[cost.md](cost.md).", "",
         "## Cells: RCB, 8 mm/s, 1.5 mm", "",
         "| architecture | printed cells | read right, over every printed cell | over the windows found | scans miscounted |",
         "| --- | --- | --- | --- | --- |"]
for arch in ["snn", "resnet"]:
    p = out / f"cells_rcb_{arch}.json"
    if not p.exists():
        continue
    r = json.loads(p.read_text())
    lines.append(f"| {arch} | {r['printed']} | {100 * r['accuracy_all']:.2f}% | {100 * r['accuracy']:.2f}% "
                 f"| {r['skipped_scans']} of {r['scans']} |")
lines += ["", "## Contracted sentences (UEB-SENTENCES, ueb-g2), 1.0 mm, estimated timing", "",
          "Word accuracy is 1 - WER over every printed word (inserted words count); exact compares case, digits and "
          "punctuation; blind compares lower-case letters and digits only.", "",
          "| architecture | speed | cells printed | cell error rate | words exact, as read | exact, TextBlob | exact, lexicon | "
          "blind, lexicon | reading s per s of stream (networks, filter) | lexicon, ms per s of stream |",
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
examples = []
for arch in ["snn", "resnet"]:
    for speed in [8, 16, 32]:
        p = out / f"words_{arch}_v{speed}.json"
        if not p.exists():
            continue
        r = json.loads(p.read_text())
        by = {s["spell"]: s for s in r["by_spell"]}
        lines.append(f"| {arch} | {speed} mm/s | {r['cells_printed']} | {r['cell_error_rate']:.4f} | "
                     f"{by['none']['word_accuracy']:.3f} | {by['textblob']['word_accuracy']:.3f} | "
                     f"{by['lexicon']['word_accuracy']:.3f} | {by['lexicon']['blind_word_accuracy']:.3f} | "
                     f"{r['read_s'] / max(r['stream_s'], 1e-9):.4f} | {1000 * r['spell_lexicon_s'] / max(r['stream_s'], 1e-9):.3f} |")
        if speed == 16:
            examples += [(arch, e) for e in r["examples"][:3]]
lines += ["", "## Examples (16 mm/s, trial 0, lexicon): print, cells read, print read", ""]
for arch, (print_, cells, read) in examples:
    lines.append(f"- {arch}: `{print_}` -> `{cells}` -> `{read}`")
(out / "ueb.md").write_text("\n".join(lines) + "\n")
print("\n".join(lines))
