#!/usr/bin/env bash
# Our UEB translation (`braille translate`: liblouis built into pipeline, vendored tables) against liblouis
# itself (C, the same tables), both ways, on liblouis's own backward test files and on the 2,000
# most frequent words of data/spelling/en-spelling.txt and the sentences in
# scripts/ueb/sentences.txt. liblouis must be a version that compiles the vendored tables
# (3.38 or later; Debian bookworm's 3.24 does not): LIBLOUIS=/prefix (bin/lou_translate,
# bin/lou_checkyaml, share/liblouis/tables). Writes docs/results/ueb_agreement.md.
# Usage: LIBLOUIS=/tmp/liblouis-head bash scripts/ueb/liblouis_check.sh [BRAILLE_BINARY]
set -euo pipefail
cd "$(dirname "$0")/../.."
: "${LIBLOUIS:?set LIBLOUIS to a liblouis install prefix (3.38 or later)}"
b="${1:-target/release/braille}"
export PATH="$LIBLOUIS/bin:$PATH" LD_LIBRARY_PATH="$LIBLOUIS/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export LOUIS_TABLEPATH="$PWD/liblouis/tables,$LIBLOUIS/share/liblouis/tables"
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
out=docs/results/ueb_agreement.md
version=$(lou_translate --version | head -1)
{
  echo "# UEB translation: \`braille translate\` (liblouis built in, \"ours\") against liblouis's own tools"
  echo
  echo "Made by \`LIBLOUIS=... bash scripts/ueb/liblouis_check.sh\` on $(date -u +%Y-%m-%d); liblouis: $version;"
  echo "tables: liblouis/ (liblouis $(sed -n 's/^- commit: //p' liblouis/README.md))."
  echo
  echo "## liblouis's own backward test files"
  echo
  echo "| file | code | ours: backward | ours: forward | liblouis (lou_checkyaml) |"
  echo "| --- | --- | --- | --- | --- |"
} > "$out"
for pair in "en-ueb-g1_backward.yaml ueb-g1" "en-ueb-g2_backward.yaml ueb-g2"; do
  set -- $pair
  $b translate --braille "$2" --spec "liblouis/tests/$1" --json > "$work/spec.json"
  theirs=$(cd liblouis/tests && lou_checkyaml "$1" 2>&1 | tail -1)
  python3 - "$work/spec.json" "$1" "$2" "$theirs" >> "$out" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
def cell(a):
    n = a["cases"] + a["xfail_cases"]
    if n == 0:
        return "-"
    ok = a["agree"] + a["xfail_agree"]
    return f"{ok}/{n} ({100*ok/n:.1f}%; {a['agree']}/{a['cases']} without xfail)"
print(f"| {sys.argv[2]} | {sys.argv[3]} | {cell(r['backward'])} | {cell(r['forward'])} | {sys.argv[4]} |")
PY
done
python3 - data/spelling/en-spelling.txt 2000 > "$work/words.txt" <<'PY'
import sys
rows = []
for line in open(sys.argv[1], encoding="utf-8"):
    if line.startswith(";;;") or not line.strip():
        continue
    w, n = line.split()
    rows.append((-int(n), w))
rows.sort()
for _, w in rows[: int(sys.argv[2])]:
    print(w)
PY
cat "$work/words.txt" scripts/ueb/sentences.txt > "$work/print.txt"
for code in ueb-g1 ueb-g2; do
  table=en-${code}.ctb
  lou_translate --forward "unicode.dis,$table" < "$work/print.txt" > "$work/theirs_cells.txt"
  $b translate --braille "$code" --to-cells - < "$work/print.txt" > "$work/ours_cells.txt"
  # Back: both read liblouis's cells.
  lou_translate --backward "unicode.dis,$table" < "$work/theirs_cells.txt" > "$work/theirs_text.txt"
  $b translate --braille "$code" --to-text - < "$work/theirs_cells.txt" > "$work/ours_text.txt"
  python3 - "$work" "$code" >> "$work/rows.md" <<'PY'
import sys
d, code = sys.argv[1], sys.argv[2]
read = lambda f: [l.rstrip("\n").replace("\u2800", " ") for l in open(f"{d}/{f}", encoding="utf-8")]
printed = read("print.txt")
a, b = read("theirs_cells.txt"), read("ours_cells.txt")
c, e = read("theirs_text.txt"), read("ours_text.txt")
assert len(a) == len(b) == len(c) == len(e) == len(printed), (len(a), len(b), len(c), len(e))
n = len(printed)
fw = sum(x == y for x, y in zip(a, b))
bw = sum(x == y for x, y in zip(c, e))
rt = sum(x == p for x, p in zip(e, printed))
rt_c = sum(x == p for x, p in zip(c, printed))
print(f"| {code} | {n} | {fw} ({100*fw/n:.1f}%) | {bw} ({100*bw/n:.1f}%) | {rt} ({100*rt/n:.1f}%) | {rt_c} ({100*rt_c/n:.1f}%) |")
diffs = [(p, x, y) for p, x, y in zip(printed, a, b) if x != y][:8]
diffs += [(p, x, y) for p, x, y in zip(printed, c, e) if x != y][:8]
with open(f"{d}/diffs_{code}.md", "w", encoding="utf-8") as f:
    for p, x, y in diffs:
        f.write(f"| {code} | `{p}` | `{x}` | `{y}` |\n")
PY
done
{
  echo
  echo "## Print to cells and back, ours against liblouis"
  echo
  echo "The 2,000 most frequent words of data/spelling/en-spelling.txt and the $(wc -l < scripts/ueb/sentences.txt) sentences of"
  echo "scripts/ueb/sentences.txt, one line each. Forward: the same cells. Backward: the same print from"
  echo "liblouis's cells. Round trip: print to cells (liblouis) and back gives the line again, ours and"
  echo "liblouis's (a contraction or a lowercase-only word can make liblouis's own round trip differ)."
  echo
  echo "| code | lines | forward agrees | backward agrees | round trip (ours) | round trip (liblouis) |"
  echo "| --- | --- | --- | --- | --- | --- |"
  cat "$work/rows.md"
  echo
  echo "First differences (up to 8 per direction; print, liblouis, ours):"
  echo
  echo "| code | print | liblouis | ours |"
  echo "| --- | --- | --- | --- |"
  cat "$work"/diffs_*.md
} >> "$out"
cat "$out"
