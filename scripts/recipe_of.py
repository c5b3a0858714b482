"""Print the recipe a model file records (its header's provenance), as JSON: the input of
`braille train --recipe FILE` that trained it.

    python3 scripts/recipe_of.py MODEL.safetensors > recipe.json
"""
import json
import struct
import sys

with open(sys.argv[1], 'rb') as f:
    n = struct.unpack('<Q', f.read(8))[0]
    header = json.loads(f.read(n))
print(json.dumps(json.loads(header['__metadata__']['provenance'])['recipe'], indent=1))
