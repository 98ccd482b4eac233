//! The likeness figures of issue #37, for any face-recognition embedding: photos of several
//! people, and pictures made from them (gems, grey renders of the fitted face), each picture
//! judged against every photo.

/// One picture made from a photo: whose photo, which photo, and its embedding (`None`: the
/// judge found no face in it, which counts as a miss everywhere).
pub struct Made<E> {
    pub person: usize,
    pub photo: usize,
    pub embedding: Option<E>,
}

/// The figures for one kind of picture.
#[derive(Debug, Default)]
pub struct Figures {
    pub pictures: usize,
    pub faces_found: usize,
    /// Share of pictures whose nearest photo (of all) is their own person's.
    pub nearest_own: f64,
    /// ... whose nearest photo other than their source photo is their own person's.
    pub nearest_own_held_out: f64,
    /// Mean distance to their source photo, to their person's other photos, to other people's.
    pub to_source: f64,
    pub to_own_others: f64,
    pub to_strangers: f64,
    /// Share of pictures whose mean distance to their person's photos is under the threshold;
    /// ... to their person's photos other than their source.
    pub under_threshold: f64,
    pub under_threshold_held_out: f64,
    /// Mean distance between pictures of different people, and of one person.
    pub between_people: f64,
    pub within_person: f64,
}

/// The figures of `made` against `photos` (person, embedding) under `distance`; a picture of a
/// person with only one photo has no held-out photo and is left out of the held-out figures.
pub fn judge<E>(
    photos: &[(usize, Option<E>)],
    made: &[Made<E>],
    distance: impl Fn(&E, &E) -> f64,
    threshold: f64,
) -> Figures {
    let mut f = Figures {
        pictures: made.len(),
        ..Figures::default()
    };
    let (mut n_near, mut n_near_h, mut n_under, mut n_under_h, mut n_held) = (0, 0, 0, 0, 0);
    let (mut src, mut own, mut strange) = (Mean::default(), Mean::default(), Mean::default());
    for m in made {
        let Some(e) = &m.embedding else {
            if photos.iter().filter(|p| p.0 == m.person).count() > 1 {
                n_held += 1;
            }
            continue;
        };
        f.faces_found += 1;
        let mut best: Option<(f64, usize)> = None;
        let mut best_h: Option<(f64, usize)> = None;
        let (mut all_own, mut others_own) = (Mean::default(), Mean::default());
        for (j, (person, pe)) in photos.iter().enumerate() {
            let Some(pe) = pe else { continue };
            let d = distance(e, pe);
            if best.is_none_or(|b| d < b.0) {
                best = Some((d, *person));
            }
            if j != m.photo && best_h.is_none_or(|b| d < b.0) {
                best_h = Some((d, *person));
            }
            if *person == m.person {
                all_own.add(d);
                if j == m.photo {
                    src.add(d);
                } else {
                    others_own.add(d);
                    own.add(d);
                }
            } else {
                strange.add(d);
            }
        }
        n_near += usize::from(best.is_some_and(|b| b.1 == m.person));
        n_under += usize::from(all_own.n > 0 && all_own.get() < threshold);
        if others_own.n > 0 {
            n_held += 1;
            n_near_h += usize::from(best_h.is_some_and(|b| b.1 == m.person));
            n_under_h += usize::from(others_own.get() < threshold);
        }
    }
    let share = |k: usize, n: usize| if n == 0 { 0.0 } else { k as f64 / n as f64 };
    f.nearest_own = share(n_near, made.len());
    f.under_threshold = share(n_under, made.len());
    f.nearest_own_held_out = share(n_near_h, n_held);
    f.under_threshold_held_out = share(n_under_h, n_held);
    f.to_source = src.get();
    f.to_own_others = own.get();
    f.to_strangers = strange.get();
    let (mut between, mut within) = (Mean::default(), Mean::default());
    for (i, a) in made.iter().enumerate() {
        for b in &made[i + 1..] {
            if let (Some(x), Some(y)) = (&a.embedding, &b.embedding) {
                if a.person == b.person {
                    within.add(distance(x, y));
                } else {
                    between.add(distance(x, y));
                }
            }
        }
    }
    f.between_people = between.get();
    f.within_person = within.get();
    f
}

/// The photos judged against each other (leave one out): the figures' ceiling.
pub fn photos_alone<E: Clone>(
    photos: &[(usize, Option<E>)],
    distance: impl Fn(&E, &E) -> f64,
    threshold: f64,
) -> Figures {
    let made: Vec<Made<E>> = photos
        .iter()
        .enumerate()
        .map(|(j, (person, e))| Made {
            person: *person,
            photo: j,
            embedding: e.clone(),
        })
        .collect();
    // Against itself a photo is at distance 0: only the held-out figures mean anything.
    judge(photos, &made, distance, threshold)
}

#[derive(Default)]
struct Mean {
    sum: f64,
    n: usize,
}

impl Mean {
    fn add(&mut self, v: f64) {
        self.sum += v;
        self.n += 1;
    }
    fn get(&self) -> f64 {
        if self.n == 0 {
            f64::NAN
        } else {
            self.sum / self.n as f64
        }
    }
}

/// One table row: `label | pictures | faces | nearest | held-out nearest | under | held-out
/// under | source | own | strangers | between | within`.
pub fn row(label: &str, f: &Figures) -> String {
    format!(
        "| {label} | {} | {} | {:.0} % | {:.0} % | {:.0} % | {:.0} % | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
        f.pictures,
        f.faces_found,
        100.0 * f.nearest_own,
        100.0 * f.nearest_own_held_out,
        100.0 * f.under_threshold,
        100.0 * f.under_threshold_held_out,
        f.to_source,
        f.to_own_others,
        f.to_strangers,
        f.between_people,
        f.within_person
    )
}

/// The header of [`row`]'s table.
pub const HEADER: &str = "| pictures | n | faces found | nearest photo own person | ... of the others (held out) | own photos under threshold | ... held out | to source photo | to own other photos | to strangers' photos | between people | within a person |\n|---|---|---|---|---|---|---|---|---|---|---|---|";
