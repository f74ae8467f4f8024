#!/usr/bin/env bash
# A second bare H200, 2026-11-29 03:03-03:10 UTC (the device tool's command, unfolded), the tree of 78db473:
# the update with the transitions switched by sed to conv-then-pool first, then pool-first (the code).
export PYTHONPATH=.
S='s/return c(nn.avg_pool(x, (2, 2), strides=(2, 2), padding="VALID"))/return nn.avg_pool(c(x), (2, 2), strides=(2, 2), padding="VALID")/'
R='s/return nn.avg_pool(c(x), (2, 2), strides=(2, 2), padding="VALID")/return c(nn.avg_pool(x, (2, 2), strides=(2, 2), padding="VALID"))/'
U="timeout 270 python3 -u bench/train_throughput.py --config gpu --updates-only --no-parts --trunks densenet121 --cache-dir off"
f(){ grep -v "^W0\|^I0\|^E0\|Delay kernel\|onstant fold\|pad.49\|necessarily a bug\|file a bug\|^$" ; }
date -u > $OUT/log.txt; sed -i "$S" vags_jax/nets/densenet.py; grep -n "nn.avg_pool" vags_jax/nets/densenet.py >> $OUT/log.txt
$U --out $OUT/mfu_densenet121_convpool_h200.json 2>&1 | f | tail -6 >> $OUT/log.txt
date -u >> $OUT/log.txt; sed -i "$R" vags_jax/nets/densenet.py; grep -n "nn.avg_pool" vags_jax/nets/densenet.py >> $OUT/log.txt
$U --out $OUT/mfu_densenet121_poolfirst_h200.json 2>&1 | f | tail -6 >> $OUT/log.txt
date -u >> $OUT/log.txt
