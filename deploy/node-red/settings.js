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
};
