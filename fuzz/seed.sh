#!/bin/sh
# Seeds fuzz/corpus/{scene,obj} from the project's scenes and, when it is there, the course's
# scenes beside the repository (../shared/mit6837/a2; read at run time, never committed).
set -eu
cd "$(dirname "$0")"
mkdir -p corpus/scene corpus/obj
for dir in ../scenes ../scenes/hard ../../shared/mit6837/a2; do
    [ -d "$dir" ] || continue
    for f in "$dir"/*.txt; do
        case "$f" in */commands.txt) continue ;; esac
        cp "$f" corpus/scene/
    done
    for f in "$dir"/*.obj; do
        [ -e "$f" ] && cp "$f" corpus/obj/
    done
done
ls corpus/scene | wc -l | xargs echo "scene seeds:"
ls corpus/obj | wc -l | xargs echo "obj seeds:"
