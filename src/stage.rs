//! Timed stages: every step of the program reports how long it took.

use std::time::Instant;

/// One timed stage.
#[derive(Clone, Debug)]
pub struct Stage {
    pub name: &'static str,
    pub ms: f64,
    pub detail: String,
}

/// Runs `f`, appending its time and a description of its result to `stages`.
pub fn timed<T, E>(
    stages: &mut Vec<Stage>,
    name: &'static str,
    f: impl FnOnce() -> Result<T, E>,
    describe: impl FnOnce(&T) -> String,
) -> Result<T, E> {
    let t = Instant::now();
    let out = f()?;
    stages.push(Stage {
        name,
        ms: t.elapsed().as_secs_f64() * 1e3,
        detail: describe(&out),
    });
    Ok(out)
}
