//! What the person pass found, said for people (the stage line: `hair short curly (...)`)
//! and for scripts (the `person` object of the `--json` reports: each decision by name with
//! the measures behind it; `docs/report.schema.json`). Lengths in face lengths (eyes to chin),
//! shares of a region 0..1.

/// The stage line's account of the person: each decision with its measures.
pub(super) fn describe_person(p: &crate::person::Person) -> String {
    let yes = |b: bool| if b { "yes" } else { "no" };
    let hair = match p.hair {
        Some(h) => format!(
            "hair {} {} (ends {:.2} face lengths below the eyes, stands {:.2}, curl {:.2}, coherence {:.2})",
            p.hair_length().as_str(),
            p.hair_kind().as_str(),
            h.length,
            h.top.max(0.7 * h.sides),
            h.curl,
            h.texture.coherence,
        ),
        None => "hair bald".into(),
    };
    let hat = if p.has_hat() {
        format!(
            "; a hat, left out of the hair (colour {:.0} from the hair's)",
            p.hat
        )
    } else {
        String::new()
    };
    // "beard stubble" where only the texture found it; the stubble's ratio beside the share.
    let beard = if p.stubble_only() {
        "stubble"
    } else {
        yes(p.has_beard())
    };
    format!(
        "{hair}{hat}; beard {beard} ({:.0} %, stubble {:.1}), moustache {} ({:.0} %, stubble {:.1}), glasses {} (bridge {:.1})",
        100.0 * p.beard,
        p.stubble.ratio(),
        yes(p.has_moustache()),
        100.0 * p.moustache,
        p.stubble.lip_ratio(),
        yes(p.has_glasses()),
        p.glasses.bridge,
    )
}

/// The person's decisions and their measures, for `--json` reports: a script reads the hair's
/// length, the beard, the moustache and the glasses by name.
pub fn person_json(p: &crate::person::Person) -> serde_json::Value {
    let hair = p.hair.map(|h| {
        serde_json::json!({
            "crown": h.crown,
            "stands_face_lengths": h.top.max(0.7 * h.sides),
            "top_face_lengths": h.top,
            "sides_face_lengths": h.sides,
            "ends_face_lengths": h.length,
            "curtain": h.curtain,
            "curl": h.curl,
            "coherence": h.texture.coherence,
            "brightness": h.brightness,
        })
    });
    serde_json::json!({
        "hair": {
            "length": p.hair_length().as_str(),
            "kind": p.hair_kind().as_str(),
            "measures": hair,
        },
        "beard": {
            "found": p.has_beard(),
            "stubble_only": p.stubble_only(),
            "chin_share": p.beard,
            "jaw_share": p.beard_jaw,
            "chin_stubble": p.stubble.ratio(),
        },
        "moustache": {
            "found": p.has_moustache(),
            "lip_share": p.moustache,
            "lip_stubble": p.stubble.lip_ratio(),
        },
        "hat": { "found": p.has_hat(), "chroma_from_hair": p.hat },
        "glasses": {
            "found": p.has_glasses(),
            "bridge_line": p.glasses.bridge,
            "lens_brightness": p.glasses.lenses,
            "dark_bar": p.glasses.dip,
        },
    })
}
