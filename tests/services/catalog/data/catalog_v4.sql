-- a gaitcap catalog of schema version 4, written by release b949fb4^ (tests/services/catalog/make_catalog_v4.py)
BEGIN TRANSACTION;
CREATE TABLE audit_log (
	id INTEGER NOT NULL, 
	at FLOAT NOT NULL, 
	actor VARCHAR(128) NOT NULL, 
	action VARCHAR(32) NOT NULL, 
	trial_id VARCHAR(64), 
	detail TEXT NOT NULL, 
	PRIMARY KEY (id)
);
INSERT INTO "audit_log" VALUES(1,1.79592307063221383097e+09,'anna','start','T20261129-033110-7fbda7','subject P0042');
INSERT INTO "audit_log" VALUES(2,1.79592307071418333047e+09,'anna','stop','T20261129-033110-7fbda7','');
INSERT INTO "audit_log" VALUES(3,1.79592307088074231149e+09,'ben','view','T20261129-033110-7fbda7','');
INSERT INTO "audit_log" VALUES(4,1.79592307088238763808e+09,'anna','start','T20261129-033110-71ad25','subject P0042');
INSERT INTO "audit_log" VALUES(5,1.79592307090278100962e+09,'anna','stop','T20261129-033110-71ad25','');
INSERT INTO "audit_log" VALUES(6,1.79592307098162174217e+09,'ben','view','T20261129-033110-71ad25','');
INSERT INTO "audit_log" VALUES(7,1.79592307100169324869e+09,'anna','start','T20261129-033110-9cb374','subject P0042');
INSERT INTO "audit_log" VALUES(8,1.7959230710377707481e+09,'anna','stop','T20261129-033110-9cb374','');
INSERT INTO "audit_log" VALUES(9,1.79592307108334064483e+09,'anna','start','T20261129-033111-6c1069','subject P0042');
INSERT INTO "audit_log" VALUES(10,1795923071.15861,'anna','correct','T20261129-033110-71ad25','session visit2');
CREATE TABLE calibration_versions (
	calibration_id VARCHAR(64) NOT NULL, 
	replaces_id VARCHAR(64), 
	made_by VARCHAR(64) NOT NULL, 
	trials_json TEXT NOT NULL, 
	comparison_json TEXT NOT NULL, 
	created_at FLOAT NOT NULL, 
	applied_at FLOAT, 
	PRIMARY KEY (calibration_id), 
	FOREIGN KEY(calibration_id) REFERENCES calibrations (id), 
	FOREIGN KEY(replaces_id) REFERENCES calibrations (id)
);
INSERT INTO "calibration_versions" VALUES('C20261129-033110-424600','C20261129-033110-e0f882','refine-rig','[]','{"cam_01": {"centre_mm": 3.0, "rotation_deg": 0.4, "focal_pct": 0.1}}',1.79592307044440126426e+09,NULL);
CREATE TABLE calibrations (
	id VARCHAR(64) NOT NULL, 
	created_at FLOAT NOT NULL, 
	source VARCHAR(256) NOT NULL, 
	toml TEXT NOT NULL, 
	report_json TEXT NOT NULL, 
	kind VARCHAR(32) NOT NULL, 
	state VARCHAR(16) NOT NULL, 
	recording_slot INTEGER, 
	done_at FLOAT, 
	started_at FLOAT, 
	stopped_at FLOAT, 
	started_by VARCHAR(128) NOT NULL, 
	recording_path VARCHAR(1024) NOT NULL, 
	frames INTEGER, 
	stage VARCHAR(64) NOT NULL, 
	progress FLOAT NOT NULL, 
	error TEXT NOT NULL, 
	board TEXT NOT NULL, 
	PRIMARY KEY (id), 
	UNIQUE (recording_slot)
);
INSERT INTO "calibrations" VALUES('C20261129-033110-e0f882',1.79592307039941334722e+09,'uploaded by anna','[cam_01]
name = ''cam_01''
','{}','uploaded','done',NULL,1.79592307039941334722e+09,NULL,NULL,'','',NULL,'',0.0,'','');
INSERT INTO "calibrations" VALUES('C20261129-033110-424600',1.79592307044440126426e+09,'refine-rig from C20261129-033110-e0f882','[cam_01]
name = ''cam_01''
# refined
','{}','refined from people','done',NULL,1.79592307044440126426e+09,NULL,NULL,'','',NULL,'',0.0,'','');
CREATE TABLE jobs (
	id INTEGER NOT NULL, 
	trial_id VARCHAR(64), 
	calibration_id VARCHAR(64), 
	kind VARCHAR(32) NOT NULL, 
	state VARCHAR(16) NOT NULL, 
	attempts INTEGER NOT NULL, 
	max_attempts INTEGER NOT NULL, 
	worker_id VARCHAR(128) NOT NULL, 
	lease_expires_at FLOAT NOT NULL, 
	created_at FLOAT NOT NULL, 
	started_at FLOAT, 
	finished_at FLOAT, 
	error TEXT NOT NULL, 
	PRIMARY KEY (id), 
	FOREIGN KEY(trial_id) REFERENCES trials (id), 
	FOREIGN KEY(calibration_id) REFERENCES calibrations (id)
);
INSERT INTO "jobs" VALUES(1,'T20261129-033110-7fbda7',NULL,'process','done',1,3,'host-1',1.79592310071461343764e+09,1.79592307071250891683e+09,1.79592307071461343764e+09,1.79592307084454464913e+09,'');
INSERT INTO "jobs" VALUES(2,'T20261129-033110-71ad25',NULL,'process','done',1,3,'host-1',1795923100.90319,1.79592307090205860137e+09,1795923070.90319,1.79592307098000478747e+09,'');
INSERT INTO "jobs" VALUES(3,'T20261129-033110-9cb374',NULL,'process','failed',1,3,'host-1',1.79592310103838825223e+09,1.79592307102029061314e+09,1.79592307103838825232e+09,1795923071.04135,'no keypoints recorded');
CREATE TABLE method_results (
	id INTEGER NOT NULL, 
	trial_id VARCHAR(64) NOT NULL, 
	method VARCHAR(32) NOT NULL, 
	params_key VARCHAR(32) NOT NULL, 
	spec_json TEXT NOT NULL, 
	config_json TEXT NOT NULL, 
	status VARCHAR(16) NOT NULL, 
	error TEXT NOT NULL, 
	created_at FLOAT NOT NULL, 
	elapsed_s FLOAT NOT NULL, 
	worker VARCHAR(128) NOT NULL, 
	skeleton VARCHAR(32) NOT NULL, 
	metrics_json TEXT NOT NULL, 
	gait_json TEXT NOT NULL, 
	residuals_json TEXT NOT NULL, 
	artifacts_json TEXT NOT NULL, 
	PRIMARY KEY (id), 
	UNIQUE (trial_id, method, params_key)
);
INSERT INTO "method_results" VALUES(1,'T20261129-033110-7fbda7','robust','0123456789abcdef','{"method": "robust"}','{"method": "robust"}','ok','',1.79592307109763932226e+09,1.5,'host-1','halpe26','{"GC_10": 0.8}','{"steps": 4}','{"reference": "walkway"}','{}');
CREATE TABLE patient_details (
	subject_id VARCHAR(64) NOT NULL, 
	sex VARCHAR(16) NOT NULL, 
	birth_year INTEGER, 
	notes TEXT NOT NULL, 
	updated_at FLOAT NOT NULL, 
	PRIMARY KEY (subject_id), 
	FOREIGN KEY(subject_id) REFERENCES subjects (id)
);
INSERT INTO "patient_details" VALUES('P0042','female',1961,'',1.79592307057327437401e+09);
CREATE TABLE results (
	id INTEGER NOT NULL, 
	trial_id VARCHAR(64) NOT NULL, 
	stage VARCHAR(16) NOT NULL, 
	method VARCHAR(128) NOT NULL, 
	created_at FLOAT NOT NULL, 
	elapsed_s FLOAT NOT NULL, 
	report_json TEXT NOT NULL, 
	quality_json TEXT NOT NULL, 
	artifacts_json TEXT NOT NULL, 
	PRIMARY KEY (id), 
	UNIQUE (trial_id, stage), 
	FOREIGN KEY(trial_id) REFERENCES trials (id)
);
INSERT INTO "results" VALUES(1,'T20261129-033110-7fbda7','preliminary','robust triangulation',1.79592307077096247679e+09,2.5,'{"warnings": [], "data_quality": {"serious": false}}','{"gc_10": 0.97}','{"gait_json": "/srv/gaitcap-v4/trials/T20261129-033110-7fbda7/preliminary/gait.json", "trajectory_npz": "/srv/gaitcap-v4/trials/T20261129-033110-7fbda7/preliminary/trajectory.npz"}');
INSERT INTO "results" VALUES(2,'T20261129-033110-7fbda7','refined','implicit trajectory fit',1.79592307080705070499e+09,2.5,'{"warnings": [], "data_quality": {"serious": false}}','{"gc_10": 0.97}','{"gait_json": "/srv/gaitcap-v4/trials/T20261129-033110-7fbda7/refined/gait.json", "trajectory_npz": "/srv/gaitcap-v4/trials/T20261129-033110-7fbda7/refined/trajectory.npz"}');
INSERT INTO "results" VALUES(3,'T20261129-033110-71ad25','preliminary','robust triangulation',1.79592307093244218821e+09,2.5,'{"warnings": [], "data_quality": {"serious": true}}','{"gc_10": 0.97}','{"gait_json": "/srv/gaitcap-v4/trials/T20261129-033110-71ad25/preliminary/gait.json", "trajectory_npz": "/srv/gaitcap-v4/trials/T20261129-033110-71ad25/preliminary/trajectory.npz"}');
INSERT INTO "results" VALUES(4,'T20261129-033110-71ad25','refined','implicit trajectory fit',1.79592307097790360452e+09,2.5,'{"warnings": [], "data_quality": {"serious": true}}','{"gc_10": 0.97}','{"gait_json": "/srv/gaitcap-v4/trials/T20261129-033110-71ad25/refined/gait.json", "trajectory_npz": "/srv/gaitcap-v4/trials/T20261129-033110-71ad25/refined/trajectory.npz"}');
CREATE TABLE schema_info (
	"key" VARCHAR(64) NOT NULL, 
	value VARCHAR(256) NOT NULL, 
	PRIMARY KEY ("key")
);
INSERT INTO "schema_info" VALUES('version','4');
INSERT INTO "schema_info" VALUES('created_at','1795923070.398');
CREATE TABLE sessions (
	id VARCHAR(140) NOT NULL, 
	subject_id VARCHAR(64) NOT NULL, 
	created_at FLOAT NOT NULL, 
	PRIMARY KEY (id), 
	FOREIGN KEY(subject_id) REFERENCES subjects (id)
);
INSERT INTO "sessions" VALUES('P0042/visit1','P0042',1.795923070593527317e+09);
INSERT INTO "sessions" VALUES('P0042/visit2','P0042',1.79592307114420795437e+09);
CREATE TABLE steps (
	id INTEGER NOT NULL, 
	result_id INTEGER NOT NULL, 
	"index" INTEGER NOT NULL, 
	side VARCHAR(8) NOT NULL, 
	time_s FLOAT NOT NULL, 
	values_json TEXT NOT NULL, 
	PRIMARY KEY (id), 
	FOREIGN KEY(result_id) REFERENCES results (id) ON DELETE CASCADE
);
INSERT INTO "steps" VALUES(1,1,0,'left',1.0,'{"side": "left", "time_s": 1.0, "step_length_mm": 600.0, "step_width_mm": 110.0}');
INSERT INTO "steps" VALUES(2,1,1,'right',1.55,'{"side": "right", "time_s": 1.55, "step_length_mm": 601.0, "step_width_mm": 109.0}');
INSERT INTO "steps" VALUES(3,1,2,'left',2.1,'{"side": "left", "time_s": 2.1, "step_length_mm": 602.0, "step_width_mm": 108.0}');
INSERT INTO "steps" VALUES(4,1,3,'right',2.65000000000000035527e+00,'{"side": "right", "time_s": 2.6500000000000004, "step_length_mm": 603.0, "step_width_mm": 107.0}');
INSERT INTO "steps" VALUES(5,2,0,'left',1.0,'{"side": "left", "time_s": 1.0, "step_length_mm": 600.0, "step_width_mm": 110.0}');
INSERT INTO "steps" VALUES(6,2,1,'right',1.55,'{"side": "right", "time_s": 1.55, "step_length_mm": 601.0, "step_width_mm": 109.0}');
INSERT INTO "steps" VALUES(7,2,2,'left',2.1,'{"side": "left", "time_s": 2.1, "step_length_mm": 602.0, "step_width_mm": 108.0}');
INSERT INTO "steps" VALUES(8,2,3,'right',2.65000000000000035527e+00,'{"side": "right", "time_s": 2.6500000000000004, "step_length_mm": 603.0, "step_width_mm": 107.0}');
INSERT INTO "steps" VALUES(9,3,0,'left',1.0,'{"side": "left", "time_s": 1.0, "step_length_mm": 600.0, "step_width_mm": 110.0}');
INSERT INTO "steps" VALUES(10,3,1,'right',1.55,'{"side": "right", "time_s": 1.55, "step_length_mm": 601.0, "step_width_mm": 109.0}');
INSERT INTO "steps" VALUES(11,3,2,'left',2.1,'{"side": "left", "time_s": 2.1, "step_length_mm": 602.0, "step_width_mm": 108.0}');
INSERT INTO "steps" VALUES(12,3,3,'right',2.65000000000000035527e+00,'{"side": "right", "time_s": 2.6500000000000004, "step_length_mm": 603.0, "step_width_mm": 107.0}');
INSERT INTO "steps" VALUES(13,4,0,'left',1.0,'{"side": "left", "time_s": 1.0, "step_length_mm": 600.0, "step_width_mm": 110.0}');
INSERT INTO "steps" VALUES(14,4,1,'right',1.55,'{"side": "right", "time_s": 1.55, "step_length_mm": 601.0, "step_width_mm": 109.0}');
INSERT INTO "steps" VALUES(15,4,2,'left',2.1,'{"side": "left", "time_s": 2.1, "step_length_mm": 602.0, "step_width_mm": 108.0}');
INSERT INTO "steps" VALUES(16,4,3,'right',2.65000000000000035527e+00,'{"side": "right", "time_s": 2.6500000000000004, "step_length_mm": 603.0, "step_width_mm": 107.0}');
CREATE TABLE subjects (
	id VARCHAR(64) NOT NULL, 
	created_at FLOAT NOT NULL, 
	PRIMARY KEY (id)
);
INSERT INTO "subjects" VALUES('P0042',1.79592307050590610506e+09);
CREATE TABLE summaries (
	id INTEGER NOT NULL, 
	result_id INTEGER NOT NULL, 
	name VARCHAR(64) NOT NULL, 
	value FLOAT, 
	sd FLOAT, 
	unit VARCHAR(16) NOT NULL, 
	PRIMARY KEY (id), 
	FOREIGN KEY(result_id) REFERENCES results (id) ON DELETE CASCADE
);
INSERT INTO "summaries" VALUES(1,1,'step_length_mm',601.5,1.3,'mm');
INSERT INTO "summaries" VALUES(2,1,'cadence_steps_per_min',109.0,NULL,'steps/min');
INSERT INTO "summaries" VALUES(3,2,'step_length_mm',601.5,1.3,'mm');
INSERT INTO "summaries" VALUES(4,2,'cadence_steps_per_min',109.0,NULL,'steps/min');
INSERT INTO "summaries" VALUES(5,3,'step_length_mm',601.5,1.3,'mm');
INSERT INTO "summaries" VALUES(6,3,'cadence_steps_per_min',110.0,NULL,'steps/min');
INSERT INTO "summaries" VALUES(7,4,'step_length_mm',601.5,1.3,'mm');
INSERT INTO "summaries" VALUES(8,4,'cadence_steps_per_min',110.0,NULL,'steps/min');
CREATE TABLE trial_details (
	trial_id VARCHAR(64) NOT NULL, 
	operator VARCHAR(128) NOT NULL, 
	walking_aid VARCHAR(128) NOT NULL, 
	assistance VARCHAR(128) NOT NULL, 
	footwear VARCHAR(128) NOT NULL, 
	notes TEXT NOT NULL, 
	voided_at FLOAT, 
	voided_by VARCHAR(128) NOT NULL, 
	void_reason TEXT NOT NULL, 
	updated_at FLOAT NOT NULL, 
	PRIMARY KEY (trial_id), 
	FOREIGN KEY(trial_id) REFERENCES trials (id)
);
INSERT INTO "trial_details" VALUES('T20261129-033110-71ad25','','cane','','','walked slowly',NULL,'','',1.79592307114420795437e+09);
CREATE TABLE trial_quality (
	trial_id VARCHAR(64) NOT NULL, 
	updated_at FLOAT NOT NULL, 
	sections_json TEXT NOT NULL, 
	PRIMARY KEY (trial_id), 
	FOREIGN KEY(trial_id) REFERENCES trials (id)
);
INSERT INTO "trial_quality" VALUES('T20261129-033110-7fbda7',1.79592307066411399846e+09,'{"recorder": {"frames": 600, "warnings": []}}');
INSERT INTO "trial_quality" VALUES('T20261129-033110-71ad25',1.79592307088301777846e+09,'{"recorder": {"frames": 601, "warnings": ["cam_03: 12 frames missing"]}}');
INSERT INTO "trial_quality" VALUES('T20261129-033110-9cb374',1.79592307101799774173e+09,'{"recorder": {"frames": 602, "warnings": []}}');
CREATE TABLE trials (
	id VARCHAR(64) NOT NULL, 
	session_id VARCHAR(140) NOT NULL, 
	subject_id VARCHAR(64) NOT NULL, 
	state VARCHAR(16) NOT NULL, 
	recording_slot INTEGER, 
	created_at FLOAT NOT NULL, 
	updated_at FLOAT NOT NULL, 
	started_at FLOAT, 
	stopped_at FLOAT, 
	recording_path VARCHAR(1024) NOT NULL, 
	calibration_id VARCHAR(64), 
	stage VARCHAR(64) NOT NULL, 
	progress FLOAT NOT NULL, 
	error TEXT NOT NULL, 
	notes TEXT NOT NULL, 
	PRIMARY KEY (id), 
	FOREIGN KEY(session_id) REFERENCES sessions (id), 
	FOREIGN KEY(subject_id) REFERENCES subjects (id), 
	UNIQUE (recording_slot), 
	FOREIGN KEY(calibration_id) REFERENCES calibrations (id)
);
INSERT INTO "trials" VALUES('T20261129-033110-7fbda7','P0042/visit1','P0042','done',NULL,1.795923070593527317e+09,1.79592307087920927998e+09,1.795923070593527317e+09,NULL,'/srv/gaitcap-v4/trials/T20261129-033110-7fbda7/recording.mcap','C20261129-033110-e0f882','done',1.0,'','');
INSERT INTO "trials" VALUES('T20261129-033110-71ad25','P0042/visit2','P0042','done_with_warnings',NULL,1.79592307088131117819e+09,1.79592307114420795437e+09,1.79592307088131117819e+09,NULL,'/srv/gaitcap-v4/trials/T20261129-033110-71ad25/recording.mcap','C20261129-033110-e0f882','done',1.0,'','');
INSERT INTO "trials" VALUES('T20261129-033110-9cb374','P0042/visit1','P0042','failed',NULL,1.79592307098406815529e+09,1.79592307104236364361e+09,1.79592307098406815529e+09,NULL,'/srv/gaitcap-v4/trials/T20261129-033110-9cb374/recording.mcap','C20261129-033110-e0f882','',0.0,'no keypoints recorded','');
INSERT INTO "trials" VALUES('T20261129-033111-6c1069','P0042/visit1','P0042','recording',1,1.79592307108140826227e+09,1.79592307108140826227e+09,1.79592307108140826227e+09,NULL,'/srv/gaitcap-v4/trials/T20261129-033111-6c1069/recording.mcap','C20261129-033110-e0f882','recording',0.0,'','');
CREATE INDEX ix_calibrations_state ON calibrations (state);
CREATE INDEX ix_audit_trial_time ON audit_log (trial_id, at);
CREATE INDEX ix_sessions_subject_id ON sessions (subject_id);
CREATE INDEX ix_calibration_versions_replaces_id ON calibration_versions (replaces_id);
CREATE INDEX ix_trials_subject_id ON trials (subject_id);
CREATE INDEX ix_trials_state ON trials (state);
CREATE INDEX ix_trials_session_id ON trials (session_id);
CREATE INDEX ix_jobs_trial_id ON jobs (trial_id);
CREATE INDEX ix_jobs_state ON jobs (state);
CREATE INDEX ix_jobs_calibration_id ON jobs (calibration_id);
CREATE INDEX ix_results_trial_id ON results (trial_id);
CREATE INDEX ix_steps_result_id ON steps (result_id);
CREATE INDEX ix_summaries_result_id ON summaries (result_id);
CREATE INDEX ix_method_results_trial_id ON method_results (trial_id);
CREATE INDEX ix_method_results_params_key ON method_results (params_key);
COMMIT;
