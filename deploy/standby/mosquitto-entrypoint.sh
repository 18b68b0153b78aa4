#!/bin/sh
# Makes the dynamic-security accounts on first start (the admin, one account
# per Node-RED instance, the devices'), every topic open to them but the
# broker's control topics, then runs the broker through the image's own entrypoint.
set -eu
: "${MQTT_ADMIN_USER:?}" "${MQTT_ADMIN_PASSWORD:?}" "${MQTT_USER_A:?}" "${MQTT_PASSWORD_A:?}" "${MQTT_USER_B:?}" "${MQTT_PASSWORD_B:?}"
config=/mosquitto/data/dynamic-security.json
if [ ! -f "$config" ]; then
  mosquitto_ctrl dynsec init "$config" "$MQTT_ADMIN_USER" "$MQTT_ADMIN_PASSWORD"
  chown mosquitto:mosquitto "$config"
  fresh=1
fi
/docker-entrypoint.sh mosquitto -c /mosquitto/config/mosquitto.conf &
broker=$!
if [ "${fresh:-0}" = 1 ]; then
  ctrl() { mosquitto_ctrl -h 127.0.0.1 -u "$MQTT_ADMIN_USER" -P "$MQTT_ADMIN_PASSWORD" dynsec "$@"; }
  until ctrl listClients >/dev/null 2>&1; do sleep 1; done
  for acl in publishClientSend publishClientReceive subscribe unsubscribe; do ctrl setDefaultACLAccess "$acl" allow; done
  ctrl createClient "$MQTT_USER_A" -p "$MQTT_PASSWORD_A"
  ctrl createClient "$MQTT_USER_B" -p "$MQTT_PASSWORD_B"
  if [ -n "${MQTT_DEVICE_USER:-}" ]; then ctrl createClient "$MQTT_DEVICE_USER" -p "${MQTT_DEVICE_PASSWORD:?}"; fi
fi
wait "$broker"
