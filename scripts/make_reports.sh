#!/usr/bin/env bash
# Regenerate the committed study reports: for each folder comparisons/reports/NAME/, run
# comparisons/NAME.yaml afresh into runs/NAME/ and copy its report there (report.md and .html,
# provenance.json, per case the summary tables and figures; not the raw rows, chunks or targets).
#
#   scripts/make_reports.sh                    # every committed report
#   scripts/make_reports.sh zoo robots         # these only
#   WBIK=wbik STUDIES=dir REPORTS=dir RUNS=dir scripts/make_reports.sh [NAME...] [-- wbik study options]
set -euo pipefail
cd "$(dirname "$0")/.."
WBIK=${WBIK:-$([ -x .venv/bin/wbik ] && echo .venv/bin/wbik || echo wbik)}
STUDIES=${STUDIES:-comparisons}
REPORTS=${REPORTS:-comparisons/reports}
RUNS=${RUNS:-runs}

names=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do names+=("$1"); shift; done
[ "${1:-}" = "--" ] && shift
if [ ${#names[@]} -eq 0 ]; then
  for folder in "$REPORTS"/*/; do names+=("$(basename "$folder")"); done
fi

for name in "${names[@]}"; do
  [ -f "$STUDIES/$name.yaml" ] || { echo "make_reports: no study file $STUDIES/$name.yaml for report $name" >&2; exit 2; }
done
# every study first, the reports copied after: the checkout stays as it was committed while the rows are
# made, so each report's provenance names a clean commit
for name in "${names[@]}"; do
  study="$STUDIES/$name.yaml"
  echo "== $name: $WBIK study $study -o $RUNS/$name --fresh $*" >&2
  "$WBIK" study "$study" -o "$RUNS/$name" --fresh --no-progress "$@"
done
for name in "${names[@]}"; do
  rm -rf "${REPORTS:?}/$name"
  mkdir -p "$REPORTS/$name"
  tar -C "$RUNS/$name" --exclude=chunks --exclude=budget_curves --exclude=poses.npz --exclude=raw.csv \
      --exclude=.wbik-lock --exclude=run.json --exclude=study.json --exclude=targets.json -cf - . \
    | tar -C "$REPORTS/$name" -xf -
done
