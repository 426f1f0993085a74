#!/bin/bash
# copy each run's checkpoints/policy.pt whenever it is rewritten (one per validation evaluation)
while true; do
  for r in "$@"; do
    p=$r/checkpoints/policy.pt; [ -f $p ] || continue
    m=$(stat -c %Y $p); mkdir -p $r/snapshots
    [ -f $r/snapshots/policy_$m.pt ] || cp $p $r/snapshots/policy_$m.pt
  done
  sleep 15
done
