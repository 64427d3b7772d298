#!/usr/bin/env python3
"""Misbehaving (and one well-behaved) clients of the external-optimizer protocol, for
optimizers/external_test.cc. Usage: external_test_client.py MODE [LOG]

  log       answer every ask with 2 points (the box centre and the lower corner), append every
            message received to LOG, exit 0 on stop
  crash     answer ask 1, then exit with status 3 when asked again
  hang      read the problem, then never answer
  notjson   answer ask 1 with a line that is not JSON
  dimension answer ask 1 with a point of the wrong length
  outside   answer ask 1 with a point outside the box
  giveup    answer ask 1 with {"error": "..."}
  deep N    answer ask 1 with {"points": N nested arrays} (hostile depth)
  twice     answer every ask with two replies in one write (the second one nobody asked for)
"""
import json
import sys
import time


def reply(obj):
    sys.stdout.write(obj if isinstance(obj, str) else json.dumps(obj))
    sys.stdout.write("\n")
    sys.stdout.flush()


def main():
    mode = sys.argv[1]
    log = open(sys.argv[2], "a") if mode == "log" else None
    lower = upper = None
    asks = 0
    for line in sys.stdin:
        message = json.loads(line)
        if log:
            log.write(line)
            log.flush()
        kind = message["type"]
        if kind == "problem":
            lower, upper = message["lower"], message["upper"]
            continue
        if kind == "stop":
            return 0
        if kind != "ask":
            continue
        asks += 1
        centre = [(a + b) / 2 for a, b in zip(lower, upper)]
        if mode == "log":
            reply({"points": [centre, lower]})
        elif mode == "crash":
            if asks >= 2:
                sys.stderr.write("external_test_client: crashing on purpose\n")
                return 3
            reply({"points": [centre]})
        elif mode == "hang":
            time.sleep(3600)
        elif mode == "notjson":
            reply("this is not json")
        elif mode == "dimension":
            reply({"points": [centre, centre + [0.0]]})
        elif mode == "outside":
            reply({"points": [[u + 1.0 for u in upper]]})
        elif mode == "giveup":
            reply({"error": "no idea what to do"})
        elif mode == "deep":
            depth = int(sys.argv[2])
            reply('{"points": ' + "[" * depth + "]" * depth + "}")
        elif mode == "twice":
            one = json.dumps({"points": [centre]})
            reply(one + "\n" + one)
    return 0


if __name__ == "__main__":
    sys.exit(main())
