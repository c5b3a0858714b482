# Shell functions of the twin scripts (scripts/twin_warm.sh, scripts/twin_distill.sh), sourced.

# the chosen trial's recipe from a search log (a model file's: scripts/recipe_of.py)
trial_recipe() { python3 -c '
import json, sys
for line in open(sys.argv[1]):
    t = json.loads(line)
    if t["trial"] == int(sys.argv[2]):
        json.dump(t["recipe"], sys.stdout)
        break
else:
    sys.exit("trial %s not in %s" % (sys.argv[2], sys.argv[1]))' "$1" "$2" > "$3"; }
# the search's score of three histories: each seed's mean validation accuracy over its last 5
# epochs run and kept, then their mean
score() { python3 -c '
import json, sys
s = []
for f in sys.argv[1:]:
    v = [e["val_accuracy"] for e in json.load(open(f)) if not e.get("undone")]
    s.append(sum(v[-5:]) / len(v[-5:]))
print("%.6f %s" % (sum(s) / len(s), " ".join("%.4f" % x for x in s)))' "$@"; }
# Scores the baseline's and the candidate's three histories (DIR/BASE-{1,2,3}.json,
# DIR/CAND-{1,2,3}.json) beside the twin search's winner into DIR/validation.txt; succeeds when
# the candidate's score is above the winner's (the rule of the twin scripts).
#   above_twin NAME DIR TWIN-SCORE "BASE LABEL" BASE "CANDIDATE LABEL" CAND
above_twin() {
  local name=$1 d=$2 twin=$3 base cand
  base=$(score "$d/$5"-{1,2,3}.json)
  cand=$(score "$d/$7"-{1,2,3}.json)
  {
    echo "$name: $4 $base"
    echo "$name: $6 $cand"
    echo "$name: the twin search's winner       $twin"
  } | tee "$d/validation.txt"
  cand=${cand%% *}
  if python3 -c "import sys; sys.exit(0 if float('$cand') > float('$twin') else 1)"; then
    echo "$name: above the twin search's winner: the final models read the test split" | tee -a "$d/validation.txt"
  else
    echo "$name: not above the twin search's winner: no test split read" | tee -a "$d/validation.txt"
    return 1
  fi
}
