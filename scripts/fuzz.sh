#!/usr/bin/env bash
exec "$(dirname "$0")/../fuzz/fuzz.sh" "$@"
