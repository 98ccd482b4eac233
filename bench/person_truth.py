#!/usr/bin/env python3
"""What `person_view` read against bench/labels/person.tsv (issue #38): for the beard, the
moustache and the glasses, how many of the labelled photos it got right and how it went wrong;
for the hair, short (ends above the chin) / long / bald against the label (hair tied back or
in an updo counts as short: from the front it ends at the ears); and how often two
photos of one person are read alike; a confusion table per attribute; the curl measured on each
labelled kind of hair.

Usage: bench/person_truth.py LABELS.tsv TABLE.md [TABLE.md ...]
TABLE.md: what `cargo run --release --example person_view -- OUT PHOTO...` prints.
The thresholds are glyptic's own: beard share above 0.55, moustache above 0.5 (crates/core/src/person/mod.rs),
or the chin's / upper lip's stubble ratio above 3 (person/stubble.rs);
glasses as `person_view` decided them (1 or 0); hair longer than one face length below the eyes is long.
Standard library only."""
import sys
from collections import Counter, defaultdict


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    labels = {}
    for line in open(sys.argv[1]):
        if line.startswith('#') or line.startswith('set\t') or not line.strip():
            continue
        s, photo, person, hair, beard, moustache, glasses, kind = line.rstrip('\n').split('\t')
        labels[photo] = dict(person=person, hair=hair, beard=beard, moustache=moustache,
                             glasses=glasses, kind=kind)
    read = {}
    for table in sys.argv[2:]:
        for line in open(table):
            cells = [c.strip() for c in line.strip().strip('|').split('|')]
            if len(cells) < 12 or cells[0] in ('photo', '---') or cells[0].startswith('-'):
                continue
            name = cells[0]
            try:
                length = float(cells[5]) if cells[1] != 'bald' else 0.0
                beard, moustache, glasses = float(cells[8]), float(cells[10]), float(cells[11])
            except ValueError:
                continue
            hair = 'bald' if cells[1] == 'bald' else ('long' if length > 1.0 else 'short')
            curl = None if cells[6] == '-' else float(cells[6])
            iou = float(cells[17]) if len(cells) > 17 and cells[17] not in ('-', '') else None
            kind = cells[18] if len(cells) > 18 else None
            # Stubble (columns 23 and 25, where the table has them): the chin's or the upper
            # lip's fine detail over 3 times the cheeks' (person::STUBBLE).
            chin_stubble = float(cells[22]) if len(cells) > 24 else 0.0
            lip_stubble = float(cells[24]) if len(cells) > 24 else 0.0
            read[name] = dict(hair=hair, curl=curl, iou=iou, kind=kind,
                              beard='1' if beard > 0.55 or chin_stubble > 3.0 else '0',
                              moustache='1' if moustache > 0.5 or lip_stubble > 3.0 else '0',
                              glasses='1' if glasses > 0.5 else '0')
    both = [p for p in labels if p in read]
    print(f'{len(both)} labelled photos read ({len(labels)} labelled, '
          f'{len({labels[p]["person"] for p in both})} people)')
    print('| what | labelled | right | found where there is none | missed |')
    print('|---|---|---|---|---|')
    for what in ('beard', 'moustache', 'glasses'):
        known = [p for p in both if labels[p][what] in '01' and labels[p][what] != '']
        right = sum(read[p][what] == labels[p][what] for p in known)
        false = sum(read[p][what] == '1' and labels[p][what] == '0' for p in known)
        missed = sum(read[p][what] == '0' and labels[p][what] == '1' for p in known)
        pos = sum(labels[p][what] == '1' for p in known)
        print(f'| {what} | {len(known)} ({pos} with) | {right} | {false} | {missed} |')
    # Tied back or an updo ends at the ears seen from the front: carved short.
    expect = {'tied': 'short'}
    known = [p for p in both if labels[p]['hair'] != '-']
    for p in known:
        labels[p]['hair'] = expect.get(labels[p]['hair'], labels[p]['hair'])
    conf = Counter((labels[p]['hair'], read[p]['hair']) for p in known)
    right = sum(v for (a, b), v in conf.items() if a == b)
    print(f'| hair short / long / bald | {len(known)} | {right} | '
          + ', '.join(f'{a} read {b}: {v}' for (a, b), v in sorted(conf.items()) if a != b)
          + ' | |')
    # Confusion tables: rows what the label says, columns what was read.
    print()
    for what, classes in (('beard', '01'), ('moustache', '01'), ('glasses', '01'),
                          ('hair', ('short', 'long', 'bald'))):
        known = [p for p in both if labels[p][what] in classes]
        conf = Counter((labels[p][what], read[p][what]) for p in known)
        name = {'0': 'no', '1': 'yes'}
        print(f'| {what}: labelled \\ read | ' + ' | '.join(name.get(c, c) for c in classes) + ' |')
        print('|---' * (len(classes) + 1) + '|')
        for a in classes:
            print(f'| {name.get(a, a)} | ' + ' | '.join(str(conf[(a, b)]) for b in classes) + ' |')
        print()
    # The hair's kind: as decided (person_view's kind column) against the label (waves are
    # not told from straight hair: a wavy label is right when read straight), with the curl
    # measure per labelled kind.
    kinds = ('straight', 'curly', 'cropped', 'bald')
    same = {'wavy': 'straight'}
    known = [p for p in both if labels[p]['kind'] not in ('-', '') and read[p]['kind']]
    if known:
        conf = Counter((labels[p]['kind'], read[p]['kind']) for p in known)
        right = sum(v for (a, b), v in conf.items() if same.get(a, a) == b)
        exact = sum(v for (a, b), v in conf.items() if a == b)
        print(f'hair kind: {right} of {len(known)} agree (wavy read straight counted right; '
              f'{exact} exactly)\n')
        print('| kind: labelled \\ read | ' + ' | '.join(kinds) + ' |')
        print('|---' * (len(kinds) + 1) + '|')
        for a in ('straight', 'wavy', 'curly', 'cropped', 'bald'):
            print(f'| {a} | ' + ' | '.join(str(conf[(a, b)]) for b in kinds) + ' |')
        print()
    curls = defaultdict(list)
    for p in both:
        if read[p]['curl'] is not None:
            curls[labels[p]['kind']].append(read[p]['curl'])
    print('| labelled kind | photos | curl read: median | min | max |')
    print('|---|---|---|---|---|')
    for k, v in sorted(curls.items()):
        v.sort()
        print(f'| {k} | {len(v)} | {v[len(v) // 2]:.2f} | {v[0]:.2f} | {v[-1]:.2f} |')
    # The frontal gem's hair outline against the photo's hair (person_view's last column).
    ious = sorted(read[p]['iou'] for p in both if read[p].get('iou') is not None)
    if ious:
        print(f'\nfrontal hair outline against the photo\'s (intersection over union, '
              f'{len(ious)} photos with hair): median {ious[len(ious) // 2]:.2f}, '
              f'quartiles {ious[len(ious) // 4]:.2f} - {ious[3 * len(ious) // 4]:.2f}')
    # Two photos of one person read alike: the share of each person's photos whose four
    # readings equal the person's commonest.
    groups = defaultdict(list)
    for p in both:
        r = read[p]
        groups[labels[p]['person']].append((r['hair'], r['beard'], r['moustache'], r['glasses']))
    agree = sum(Counter(v).most_common(1)[0][1] for v in groups.values())
    print(f'\nphotos read as their person\'s commonest reading (hair, beard, moustache, '
          f'glasses): {agree} of {len(both)}')
    kinds = defaultdict(list)
    for p in both:
        if read[p]['kind']:
            kinds[labels[p]['person']].append(read[p]['kind'])
    same = sum(Counter(v).most_common(1)[0][1] for v in kinds.values())
    print(f'photos whose hair kind is their person\'s commonest: {same} of '
          f'{sum(len(v) for v in kinds.values())}')


if __name__ == '__main__':
    main()
