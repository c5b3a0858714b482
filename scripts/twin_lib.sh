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
