//! Collision geometry of rigid obstacles (rocks, tree trunks) against wheels and the chassis.
