#!/bin/sh
# Seeds fuzz/corpus/{scene,obj} from the project's scenes, fuzz/seeds (an assignment-4 scene:
# point lights, attenuation, every material field) and, when they are there, the course's
# scenes and meshes (a2, a3, a4, a6 of $RAYCASTER_CORPUS, else of ../shared/mit6837 beside the
# repository; read at run time, never committed).
set -eu
caller=$(pwd)
cd "$(dirname "$0")"
case "${RAYCASTER_CORPUS:-}" in
    "") corpus=../../shared/mit6837 ;;
    /*) corpus=$RAYCASTER_CORPUS ;;
    *) corpus=$caller/$RAYCASTER_CORPUS ;;
esac
mkdir -p corpus/scene corpus/obj
for dir in ../scenes ../scenes/hard seeds "$corpus/a2" "$corpus/a3" "$corpus/a4" "$corpus/a6"; do
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
