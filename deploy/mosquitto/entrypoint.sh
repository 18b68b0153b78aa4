#!/bin/sh
# Writes Mosquitto's password file from the environment, then starts the broker
# through the image's own entrypoint (which hands /mosquitto to the mosquitto user).
set -eu
: "${MQTT_USER:?set MQTT_USER (the account Node-RED logs in with)}"
: "${MQTT_PASSWORD:?set MQTT_PASSWORD}"
passwd=/mosquitto/data/passwd
umask 077
mosquitto_passwd -c -b "$passwd" "$MQTT_USER" "$MQTT_PASSWORD"
# The field devices' own account, when they do not share Node-RED's.
if [ -n "${MQTT_DEVICE_USER:-}" ]; then
  : "${MQTT_DEVICE_PASSWORD:?set MQTT_DEVICE_PASSWORD for MQTT_DEVICE_USER}"
  mosquitto_passwd -b "$passwd" "$MQTT_DEVICE_USER" "$MQTT_DEVICE_PASSWORD"
fi
chown mosquitto:mosquitto "$passwd"
exec /docker-entrypoint.sh mosquitto -c /mosquitto/config/mosquitto.conf
