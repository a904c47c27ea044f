// Keeps a static library target valid while its module folder has no sources yet.
