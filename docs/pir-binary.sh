# Sourced by the measuring scripts in docs/ (from the checkout's root): sets `pir`, the binary
# they measure: $PIR when set (e.g. an older build, for before/after figures), else this
# checkout's release build, built first.
pir=${PIR:-}
if [[ -z $pir ]]; then
    cargo build --release --quiet
    pir=target/release/pir
fi
