#!/usr/bin/env bash
# One bare H200, 2026-11-29 02:50-03:00 UTC (the device tool's command, unfolded): DenseNet-121's eval
# pass and its update with the transitions pooling first (the code), then with one line switched
# back by sed to torchvision's conv-then-pool order, then the pass with pool-first again.
export PYTHONPATH=.
S='s/return c(nn.avg_pool(x, (2, 2), strides=(2, 2), padding="VALID"))/return nn.avg_pool(c(x), (2, 2), strides=(2, 2), padding="VALID")/'
R='s/return nn.avg_pool(c(x), (2, 2), strides=(2, 2), padding="VALID")/return c(nn.avg_pool(x, (2, 2), strides=(2, 2), padding="VALID"))/'
U="timeout 250 python3 -u bench/train_throughput.py --config gpu --updates-only --no-parts --trunks densenet121 --cache-dir off"
P="python3 -u bench/densenet_speed.py --batches 1024 --reps 10 --forms module"
f(){ grep -v "^W0\|^I0\|^E0" ; }
date -u > $OUT/log.txt; grep -n "nn.avg_pool" vags_jax/nets/densenet.py >> $OUT/log.txt
$P --out $OUT/pass_poolfirst_1.json 2>&1 | f >> $OUT/log.txt
$U --out $OUT/mfu_densenet121_poolfirst_h200.json 2>&1 | f | tail -15 >> $OUT/log.txt
date -u >> $OUT/log.txt; sed -i "$S" vags_jax/nets/densenet.py; grep -n "nn.avg_pool" vags_jax/nets/densenet.py >> $OUT/log.txt
$P --out $OUT/pass_convpool.json 2>&1 | f >> $OUT/log.txt
$U --out $OUT/mfu_densenet121_convpool_h200.json 2>&1 | f | tail -15 >> $OUT/log.txt
date -u >> $OUT/log.txt; sed -i "$R" vags_jax/nets/densenet.py; grep -n "nn.avg_pool" vags_jax/nets/densenet.py >> $OUT/log.txt
$P --out $OUT/pass_poolfirst_2.json 2>&1 | f >> $OUT/log.txt
date -u >> $OUT/log.txt
