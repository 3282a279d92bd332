"""Generated wire-contract stubs (regenerate_stubs.sh); do not edit."""
