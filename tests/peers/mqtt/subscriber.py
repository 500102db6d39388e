"""The independent subscriber of tests/live/output_mqtt.rs (paho-mqtt 2.x).

Subscribes to every topic (`#`) at QoS 1 on the broker at 127.0.0.1:PORT
and prints one JSON line per message: its wall-clock receive time (ns,
the clock sipnpuff's `matched_at_ms` is on), topic, payload, retain flag,
QoS and DUP flag. `{"subscribed": n}` after the n-th SUBACK (it subscribes
again after every reconnect), `{"disconnected": n}` when a connection
breaks. Runs until killed.
"""

import argparse
import json
import sys
import time

import paho.mqtt.client as mqtt


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--topic", default="#")
    args = parser.parse_args()

    state = {"subscribed": 0, "disconnected": 0}

    def say(record):
        sys.stdout.write(json.dumps(record) + "\n")
        sys.stdout.flush()

    def on_connect(client, userdata, flags, reason_code, properties):
        client.subscribe(args.topic, qos=1)

    def on_subscribe(client, userdata, mid, reason_codes, properties):
        state["subscribed"] += 1
        say({"subscribed": state["subscribed"]})

    def on_disconnect(client, userdata, flags, reason_code, properties):
        state["disconnected"] += 1
        say({"disconnected": state["disconnected"]})

    def on_message(client, userdata, message):
        received_ns = time.time_ns()
        say(
            {
                "t_ns": received_ns,
                "topic": message.topic,
                "payload": message.payload.decode("utf-8", "replace"),
                "retain": bool(message.retain),
                "qos": message.qos,
                "dup": bool(message.dup),
            }
        )

    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, clean_session=True)
    client.on_connect = on_connect
    client.on_subscribe = on_subscribe
    client.on_disconnect = on_disconnect
    client.on_message = on_message
    client.reconnect_delay_set(min_delay=0.05, max_delay=0.2)
    # Retries until the broker answers (it may be restarting).
    while True:
        try:
            client.connect("127.0.0.1", args.port, keepalive=5)
            break
        except OSError:
            time.sleep(0.05)
    client.loop_forever(retry_first_connection=True)


if __name__ == "__main__":
    main()
