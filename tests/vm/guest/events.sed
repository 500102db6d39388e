# The bursts' actions, the recognised gestures and the matched modes, keys,
# clicks and home events of a JSON Lines event log, one a line (`burst -1`,
# `gesture nod`, `match translate_x`, `match key ctrl+alt+t`, `match click
# left`, `match home lights_toggle`), ticks ignored: what the VM
# harness compares. `sed -n -f events.sed`, by GNU sed on the host (the
# expected events) and busybox sed in the guest (the events seen).
s/.*"event":"burst","action":\(-\{0,1\}[0-9]*\).*/burst \1/p
s/.*"event":"gesture","name":"\([a-z0-9_]*\)".*/gesture \1/p
s/.*"event":"match".*"mode":"\([a-z_]*\)".*/match \1/p
s/.*"event":"match".*"key":"\([a-z0-9_+]*\)".*/match key \1/p
s/.*"event":"match".*"click":"\([a-z]*\)".*/match click \1/p
s/.*"event":"match".*"home_event":"\([a-z0-9_]*\)".*/match home \1/p
