//! The kiosk's configuration file (TOML): parsed and range-checked.
#![no_main]

use std::path::Path;

use glyptic::kiosk::KioskConfig;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(config) = KioskConfig::parse(text, Path::new("kiosk.toml")) {
        assert!(config.sss_strength.is_finite() && config.render_scale.is_finite());
        let _ = glyptic::kiosk::Controls::from_config(&config);
        // A configuration that passed its check holds a PIN hash that reads (issue #40).
        assert!(config.staff_pin().is_ok());
        assert!(config.snapshots_max >= 1 && config.snapshots_max_mb >= 1);
    }
});
