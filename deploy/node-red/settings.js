// Node-RED settings for the sugarshack container (deploy/node-red/Dockerfile
// copies this into /data). Everything that differs between plants comes from
// the environment; the flows read theirs as ${NAME} properties.
module.exports = {
  uiPort: Number(process.env.PORT) || 1880,
  flowFile: 'flows.json',
  flowFilePretty: true,
  // flows_cred.json holds only ${NAME} references; set a secret to encrypt what the editor adds.
  credentialSecret: process.env.NODE_RED_CREDENTIAL_SECRET || false,
  // The editor and admin API need a login once a password hash is set (node-red admin hash-pw).
  adminAuth: process.env.NODE_RED_ADMIN_PASSWORD_HASH ? {
    type: 'credentials',
    users: [{ username: process.env.NODE_RED_ADMIN_USER || 'admin', password: process.env.NODE_RED_ADMIN_PASSWORD_HASH, permissions: '*' }],
  } : undefined,
  // On disk, so a persisted interlock keeps its faults across container restarts.
  contextStorage: {
    default: { module: 'localfilesystem' },
    memory: { module: 'memory' },
  },
  logging: { console: { level: 'info', metrics: false, audit: false } },
  telemetry: { enabled: false },
  // No embedded journal: the flows' journal node writes to the database (SUGARSHACK_DB_*).
  // A hot standby (deploy/standby/): the cluster from the environment; without SUGARSHACK_ETCD_HOSTS, one instance alone.
  sugarshack: process.env.SUGARSHACK_ETCD_HOSTS ? {
    cluster: {
      name: process.env.SUGARSHACK_CLUSTER || 'sugarshack',
      instance: process.env.SUGARSHACK_INSTANCE,
      etcd: { hosts: process.env.SUGARSHACK_ETCD_HOSTS.split(',') },
      leaseTtlS: Number(process.env.SUGARSHACK_LEASE_TTL_S) || 3,
      mqtt: process.env.SUGARSHACK_FENCE_USER ? {
        url: `mqtt://${process.env.MQTT_HOST}:${process.env.MQTT_PORT}`,
        username: process.env.SUGARSHACK_FENCE_USER,
        password: process.env.SUGARSHACK_FENCE_PASSWORD,
        client: process.env.MQTT_USER,
      } : undefined,
    },
  } : undefined,
};
