"""scripts/horizon_from_vehicles.py (the horizon read off the cars in a frame's labels) on label
maps drawn from a known camera, where the horizon is known."""
import importlib.util
import pathlib

import numpy as np

SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "scripts" / "horizon_from_vehicles.py"
spec = importlib.util.spec_from_file_location("horizon_from_vehicles", SCRIPT)
hv = importlib.util.module_from_spec(spec)
spec.loader.exec_module(hv)

ROAD, BUILDING, SKY, CAR, POLE = 7, 11, 23, 26, 17
F_PX, CAM_H_M, HORIZON = 1000.0, 1.22, 200.5


def car_rows(z_m, car_h_m=1.5):
    """The rows a car H m tall at Z m spans from the camera above (pixel centres at whole rows):
    its roof's edge at y_h - f(H - h)/Z, its contact at y_h + f h / Z."""
    top_edge = HORIZON - F_PX * (car_h_m - CAM_H_M) / z_m
    bottom_edge = HORIZON + F_PX * CAM_H_M / z_m
    return int(round(top_edge + 0.5)), int(round(bottom_edge - 0.5))


def frame(cars, w=640, h=400):
    """Road below the horizon, buildings above; each car (x0, x1, top, bottom) a rectangle with
    an instance id 26000 + k."""
    lab = np.full((h, w), ROAD, np.int64)
    lab[: int(HORIZON)] = BUILDING
    lab[:60] = SKY
    inst = np.zeros((h, w), np.int64)
    for k, (x0, x1, t, b) in enumerate(cars):
        lab[t:b + 1, x0:x1] = CAR
        inst[t:b + 1, x0:x1] = 26000 + k
    return lab, inst


def test_cars_at_known_depths_give_the_horizon():
    # Z = 20 m: roof edge 186.5, contact 261.5, both on pixel edges (rows 187-261); 40 m: 193.5
    # and 231.0 (rows 194-230 hold the car's centres; the contact edge lies mid-row, half a row
    # from the counted edge, which moves y_h by (1 - h/H) * 0.5 = 0.093 px).
    cars = [(100, 180, *car_rows(20)), (300, 340, *car_rows(40))]
    assert cars[0][2:] == (187, 261)
    lab, inst = frame(cars)
    spans = hv.car_spans(lab, inst)
    assert sorted(spans) == sorted([(187, 261), (194, 230)])
    y = hv.horizon_from_cars(spans, CAM_H_M, 1.5)
    near = y[spans.index((187, 261))]
    # Float rounding of a few operations on values below 300 (1e-12 is far above their ulps).
    assert abs(near - HORIZON) < 1e-12
    far = y[spans.index((194, 230))]
    assert abs(far - HORIZON) <= 0.5 * (1 - CAM_H_M / 1.5) + 0.5 * CAM_H_M / 1.5  # each edge within half a row
    # A car assumed taller than it is (1.6 m for 1.5) puts the horizon below the true one.
    assert hv.horizon_from_cars([(187, 261)], CAM_H_M, 1.6)[0] > HORIZON


def test_cars_whose_contact_or_roof_is_hidden_or_cut_are_left_out():
    t, b = car_rows(20)
    ok = (100, 180, t, b)
    lab, inst = frame([ok, (0, 60, t, b), (250, 330, t, b), (400, 480, t, b), (520, 600, t, b)])
    lab[b + 1, 250:330] = POLE  # contact hidden: a pole base along its whole lowest row
    lab[t - 1, 400:480] = POLE  # roof hidden behind a sign's bar along its whole top row
    lab[t:b + 1, 520:600] = CAR
    lab[b + 1:, 500:620] = CAR  # a nearer car in front of its lowest row (cut by the frame's bottom)
    inst[b + 1:, 500:620] = 26009
    spans = hv.car_spans(lab, inst)
    assert spans == [(t, b)]  # the first car only; the one at x 0 is cut by the frame


def test_regions_without_instances():
    t, b = car_rows(20)
    lab, _ = frame([(100, 180, t, b)])
    assert hv.car_spans(lab) == [(t, b)]
    # Two cars side by side merge into one region 4.3 times as wide as tall: left out.
    lab2, _ = frame([(100, 200, t, b), (200, 424, t, b)])
    assert hv.car_spans(lab2) == []


def test_median_and_its_standard_error():
    m, se = hv.median_se([1.0, 2.0, 3.0, 4.0, 5.0])
    assert m == 3.0
    assert abs(se - 1.2533 * np.std([1, 2, 3, 4, 5], ddof=1) / np.sqrt(5)) < 1e-12
